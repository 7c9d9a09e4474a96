//! Prints one greedy trial step by step: `--example trace -- models/row.safetensors row 1`.
use seespot_sim::{Trial, WorldConfig};
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().collect();
    let policy = seespot_policy::PolicyNet::load(std::path::Path::new(&a[1]))?;
    let task: seespot_sim::TaskId = a[2].parse()?;
    let seed: u64 = a[3].parse()?;
    let mut trial = Trial::new(WorldConfig::default(), task, seed);
    println!("start progress {}", trial.progress());
    while trial.end().is_none() {
        let p = trial.world().next_primitive();
        let hm = trial.world_mut().observe();
        let q = policy.q_values(&hm, p)?;
        let action = seespot_policy::greedy_action(&policy, &hm, p)?;
        let qa = q.q[action.flat_index(hm.resolution())];
        let rec = trial.step(action).clone();
        println!(
            "{action} q={qa:.3} success={} failure={:?} progress {}->{} reversal={}",
            rec.outcome.success,
            rec.outcome.failure,
            rec.progress_before,
            rec.progress_after,
            rec.reversal
        );
    }
    println!("end {:?}", trial.end());
    Ok(())
}
