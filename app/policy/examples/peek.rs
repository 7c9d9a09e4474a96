//! Greedy own-task check of a run's latest checkpoint on *validation* seeds
//! (never the test seeds): `--example peek -- runs/train-stack stack 6`.
fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    use seespot_sim::{Seeds, Split};
    let a: Vec<String> = std::env::args().collect();
    let usage = "usage: peek RUN_DIR TASK [TRIALS]";
    let dir = std::path::Path::new(a.get(1).ok_or(usage)?);
    let task: seespot_sim::TaskId = a.get(2).ok_or(usage)?.parse()?;
    let n: u64 = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(6);
    let state: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("state.json"))?)?;
    let ckpt = state["checkpoint"].as_str().unwrap_or_default();
    let learner =
        seespot_policy::trainer::Learner::load_checkpoint(&dir.join(ckpt), Default::default())?;
    let records = seespot_policy::own_task_eval(
        &learner.policy,
        task,
        Seeds::new(Split::Validation.first(), n)?,
        &mut |t| {
            println!(
                "seed {} success {} actions {} max_progress {}",
                t.seed, t.success, t.actions, t.max_progress
            )
        },
    )?;
    let successes = records.iter().filter(|r| r.success).count();
    println!("success {successes}/{}", records.len());
    Ok(())
}
