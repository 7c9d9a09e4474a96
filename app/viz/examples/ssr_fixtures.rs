//! Writes stand-in SSR inputs for measuring the debugger at any resolution:
//! untrained (randomly initialized) policies `OUT/models/<task>.safetensors` and
//! oracle demos `OUT/demos/<task>/{0,2}` at `RES` px. Their compute cost is the
//! real one; their choices are not. `ssr_fixtures OUT RES`.

use std::path::PathBuf;

use seespot_policy::PolicyNet;
use seespot_sim::{Grid, TaskId, WorldConfig};
use seespot_viz::decider::load_demos;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().ok_or("usage: ssr_fixtures OUT RES")?);
    let res: usize = args.next().ok_or("usage: ssr_fixtures OUT RES")?.parse()?;
    let world = WorldConfig {
        grid: Grid::new(res),
        ..WorldConfig::default()
    };
    std::fs::create_dir_all(out.join("models"))?;
    for (i, t) in TaskId::ALL.into_iter().enumerate() {
        PolicyNet::new(t, res, i as u64)?.save(
            &out.join("models")
                .join(format!("{}.safetensors", t.as_str())),
        )?;
        let (demos, _) = load_demos(
            t,
            &seespot_ssr::Layout::new("/nonexistent", "/nonexistent"),
            world,
        )?;
        for (d, name) in demos.iter().zip(["0", "2"]) {
            d.write(&out.join("demos").join(t.as_str()).join(name))?;
        }
    }
    println!("wrote {}", out.display());
    Ok(())
}
