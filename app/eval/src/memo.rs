//! The finetunes an evaluation makes in memory (the Adam variant's SPOT-Q
//! policies, the finetuned TransporterNets), made once.
//!
//! Each is a deterministic function of its base model's bytes, the fold's
//! demonstrations and its recipe. The first run that needs one makes it and
//! keeps it in the cache folder ([`cache_dir`]) under the sha256 of those
//! inputs; every later need with the same inputs loads it: the other parallel
//! jobs of the run (which wait for the first instead of finetuning beside
//! it), the next row or evaluation, the validation seeds, the debugger's
//! replays. The records name the inputs (base and demonstrations) as before,
//! so the cache changes no record; a cache that cannot be written is a
//! warning, and the model is used as made.
//!
//! The key holds seespot's version and [`FORMAT`], not the finetuning code:
//! after a change to how a finetune is made, clear the folder
//! (`rm -r ~/.cache/seespot/finetuned`).

use std::path::{Path, PathBuf};
use std::sync::Mutex;

use crate::config::EvalError;

/// Raised when what a cached file holds, or how its key is made, changes.
pub const FORMAT: u32 = 1;

/// One finetune at a time in this process: a parallel job that needs the
/// model another is making waits for it and loads it.
static MAKING: Mutex<()> = Mutex::new(());

thread_local! {
    static WITHOUT_CACHE: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `work` on this thread with the finetune cache neither read nor
/// written: finetunes come from the shipped folder or are made. What checks
/// that the shipped folder holds what a run needs uses it (with a raised
/// stop flag, [`seespot_policy::cancel`], a missing finetune is then an
/// error instead of minutes of work).
pub fn without_cache<T>(work: impl FnOnce() -> T) -> T {
    let before = WITHOUT_CACHE.replace(true);
    struct Restore(bool);
    impl Drop for Restore {
        fn drop(&mut self) {
            WITHOUT_CACHE.set(self.0);
        }
    }
    let _restore = Restore(before);
    work()
}

/// Where finetunes are kept: `$SEESPOT_CACHE/finetuned`, else
/// `$XDG_CACHE_HOME/seespot/finetuned`, else `~/.cache/seespot/finetuned`
/// (`None` without a home).
pub fn cache_dir() -> Option<PathBuf> {
    let var = |k: &str| {
        std::env::var_os(k)
            .filter(|v| !v.is_empty())
            .map(PathBuf::from)
    };
    let root = var("SEESPOT_CACHE")
        .or_else(|| var("XDG_CACHE_HOME").map(|d| d.join("seespot")))
        .or_else(|| var("HOME").map(|h| h.join(".cache").join("seespot")))?;
    Some(root.join("finetuned"))
}

/// The file name of a finetune of `kind` made from `inputs` (checksums and
/// recipe, as JSON), in the cache and in the shipped folder alike.
pub fn file_name(kind: &str, inputs: &serde_json::Value) -> String {
    use sha2::{Digest, Sha256};
    let text = serde_json::json!({
        "seespot": seespot_sim::VERSION,
        "format": FORMAT,
        "kind": kind,
        "inputs": inputs,
    })
    .to_string();
    let hex: String = Sha256::digest(text.as_bytes())
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect();
    format!("{kind}-{}.safetensors", &hex[..32])
}

/// The folder of the finetunes shipped beside the base models in `models`
/// (made by `scripts/make-finetunes`): `<models>/finetuned/`, named as the
/// cache names them and read before it.
pub fn shipped_dir(models: &Path) -> PathBuf {
    models.join("finetuned")
}

/// The finetune of `kind` from `inputs`: loaded from the shipped folder
/// (`shipped`, read only) or the cache where it is there (`load`), else made
/// (`make`), kept in the cache (`save`, to the path it is given) and
/// returned. A shipped file that cannot be read is a warning, and the cache
/// is tried next.
pub fn get_or_make<T>(
    kind: &str,
    inputs: &serde_json::Value,
    shipped: &Path,
    load: impl Fn(&Path) -> Result<T, EvalError>,
    save: impl FnOnce(&T, &Path) -> Result<(), EvalError>,
    make: impl FnOnce() -> Result<T, EvalError>,
) -> Result<T, EvalError> {
    let name = file_name(kind, inputs);
    let shipped = shipped.join(&name);
    if shipped.is_file() {
        match load(&shipped) {
            Ok(model) => return Ok(model),
            Err(e) => eprintln!(
                "warning: the shipped finetune {} cannot be read ({e}); trying the cache",
                shipped.display()
            ),
        }
    }
    let Some(dir) = cache_dir().filter(|_| !WITHOUT_CACHE.get()) else {
        return make();
    };
    let path = dir.join(&name);
    let _making = MAKING
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if path.is_file() {
        match load(&path) {
            Ok(model) => return Ok(model),
            Err(e) => eprintln!(
                "warning: the cached finetune {} cannot be read ({e}); making it again",
                path.display()
            ),
        }
    }
    let model = make()?;
    // `save` writes a weights file whole or not at all, its folder made
    // (`seespot_policy::tensor_file`).
    if let Err(e) = save(&model, &path) {
        eprintln!("warning: the finetune could not be kept in the cache ({e}); using it as made");
    }
    Ok(model)
}
