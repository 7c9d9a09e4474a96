//! Prints the policy timing report: `cargo run --release -p seespot-policy --example bench`.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let iters = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(5);
    let report = seespot_policy::bench::bench(&[224, 112], iters)?;
    println!("{}", serde_json::to_string_pretty(&report)?);
    Ok(())
}
