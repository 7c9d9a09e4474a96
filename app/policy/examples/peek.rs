//! Greedy own-task check of a run's latest checkpoint:
//! `--example peek -- runs/train-stack stack 6`.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    let dir = std::path::Path::new(&a[1]);
    let task: seespot_sim::TaskId = a[2].parse()?;
    let n: usize = a.get(3).and_then(|s| s.parse().ok()).unwrap_or(6);
    let state: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("state.json"))?)?;
    let ckpt = state["checkpoint"].as_str().unwrap_or_default();
    let learner = seespot_policy::trainer::Learner::load_checkpoint(&dir.join(ckpt))?;
    let r = seespot_policy::own_task_eval(
        &learner.policy,
        task,
        Default::default(),
        n,
        1000,
        &mut |t| {
            println!(
                "seed {} success {} actions {} max_progress {}",
                t.seed, t.success, t.actions, t.max_progress
            )
        },
    )?;
    println!(
        "{ckpt}: success {:.2} progress {:.2}",
        r.success_rate, r.progress
    );
    Ok(())
}
