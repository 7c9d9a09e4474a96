//! `seespot sim run --policy P` plays at the resolution the policy was
//! trained at, unless `--resolution` (or a scene) says otherwise, so a model
//! card's re-measure command measures what the card reports.

mod common;
use common::{root, run_in};

fn resolution_of(args: &[&str]) -> u64 {
    let (code, out, err) = run_in(&root(), args);
    assert_eq!(code, 0, "{err}");
    let v: serde_json::Value = serde_json::from_str(&out).expect("one JSON object");
    v["resolution"].as_u64().expect("resolution")
}

#[test]
fn sim_run_plays_at_the_policys_own_resolution() {
    let run = |policy: &str, extra: &[&str]| {
        let mut args = vec![
            "sim", "run", "--policy", policy, "--task", "unstack", "--trials", "1", "--json",
        ];
        args.extend(extra);
        resolution_of(&args)
    };
    assert_eq!(run("models/unstack.safetensors", &[]), 224);
    assert_eq!(run("models/oracle-guided/unstack.safetensors", &[]), 112);
    assert_eq!(
        run("models/unstack.safetensors", &["--resolution", "112"]),
        112
    );
    assert_eq!(run("oracle", &[]), 224, "the oracle plays at the default");
}
