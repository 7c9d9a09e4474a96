//! Issue 59, item 5: every path that runs Python finds the package or says
//! exactly what to install. `seespot export lerobot` looks for a Python with
//! the package (`SEESPOT_PYTHON`, then `.venv` and `.venv-py` here or above,
//! then `python3`) and, with none, names each one tried, the module it lacks
//! and the install command; the README's ONNX example and the other examples
//! say what to install.

use std::path::Path;
use std::process::Command;

mod common;
use common::{root, seespot};

/// A stand-in interpreter at `path`: it passes the import check and, run as
/// the exporter, writes its arguments to `marker`.
fn fake_python(path: &Path, marker: &Path) {
    use std::os::unix::fs::PermissionsExt;
    std::fs::create_dir_all(path.parent().expect("parent")).expect("mkdir");
    std::fs::write(
        path,
        format!(
            "#!/bin/sh\nif [ \"$1\" = -c ]; then exit 0; fi\necho \"$@\" > '{}'\n",
            marker.display()
        ),
    )
    .expect("write");
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).expect("chmod");
}

/// A real Python that has no site-packages at all (`python3 -I -S`), as an
/// interpreter file; `None` without python3.
fn bare_python(dir: &Path) -> Option<std::path::PathBuf> {
    use std::os::unix::fs::PermissionsExt;
    let python3 = which("python3")?;
    let path = dir.join("bare-python");
    std::fs::write(
        &path,
        format!("#!/bin/sh\nexec '{}' -I -S \"$@\"\n", python3.display()),
    )
    .expect("write");
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).expect("chmod");
    Some(path)
}

fn which(name: &str) -> Option<std::path::PathBuf> {
    std::env::var_os("PATH")?
        .to_str()?
        .split(':')
        .map(|d| Path::new(d).join(name))
        .find(|p| p.is_file())
}

#[test]
fn issue_59_export_lerobot_without_the_package_says_what_to_install() {
    let dir = tempfile::tempdir().expect("tempdir");
    let Some(python) = bare_python(dir.path()) else {
        eprintln!("no python3 here: nothing to check");
        return;
    };
    let out = dir.path().join("ds");
    let o = seespot()
        .args(["export", "lerobot", "--demos", "demos", "--out"])
        .arg(&out)
        .env("SEESPOT_PYTHON", &python)
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    for words in [
        &format!("{} has no module `seespot", python.display())[..],
        "pip install '.[lerobot]'",
        "scripts/test-python",
        "SEESPOT_PYTHON",
    ] {
        assert!(err.contains(words), "no `{words}` in: {err}");
    }
    assert!(!err.contains("Traceback"), "{err}");
    assert!(!out.exists(), "it wrote {}", out.display());
}

#[test]
fn issue_59_export_lerobot_finds_the_repositorys_venv() {
    // A folder below one holding `.venv-py`, as the repository's is.
    let dir = tempfile::tempdir().expect("tempdir");
    let marker = dir.path().join("ran");
    fake_python(&dir.path().join(".venv-py/bin/python"), &marker);
    let below = dir.path().join("work");
    std::fs::create_dir(&below).expect("mkdir");
    let o = seespot()
        .current_dir(&below)
        .args(["export", "lerobot", "--demos", "demos", "--out", "ds"])
        .env_remove("SEESPOT_PYTHON")
        .output()
        .expect("run");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    let args = std::fs::read_to_string(&marker).expect("the venv's python ran");
    assert_eq!(
        args.trim(),
        "-m seespot.export lerobot --demos demos --out ds"
    );
}

#[test]
fn issue_59_the_examples_say_what_to_install() {
    let dir = tempfile::tempdir().expect("tempdir");
    let Some(python) = bare_python(dir.path()) else {
        eprintln!("no python3 here: nothing to check");
        return;
    };
    for (example, missing) in [
        ("ssr_onnx_network.py --view", "numpy"),
        ("ssr_own_embeddings.py", "numpy"),
        ("env_stepping.py", "gymnasium"),
        ("ray_evaluation.py", "seespot"),
    ] {
        let mut words = example.split(' ');
        let file = words.next().expect("a file");
        let o = Command::new(&python)
            .arg(root().join("python/examples").join(file))
            .args(words)
            .current_dir(root())
            .output()
            .expect("run");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{example}: {err}");
        for w in [
            &format!("has no module '{missing}'")[..],
            "scripts/test-python",
            "python3 -m venv .venv && .venv/bin/pip install ",
            &format!("python/examples/{file}"),
        ] {
            assert!(err.contains(w), "{example}: no `{w}` in: {err}");
        }
        assert!(!err.contains("Traceback"), "{example}: {err}");
    }
}
