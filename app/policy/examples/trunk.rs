//! Breakdown of the forward pass: `cargo run --release -p seespot-policy --example trunk`.
#![allow(clippy::unwrap_used)]
use candle_core::{Device, Tensor};
use std::time::Instant;
fn main() {
    let net = seespot_policy::net::QNet::new(0).unwrap();
    for b in [16usize, 8, 1] {
        let x = Tensor::zeros((b, 4, 112, 112), candle_core::DType::F32, &Device::Cpu).unwrap();
        let mut best = f64::MAX;
        for _ in 0..8 {
            let t = Instant::now();
            let y = net.trunk(&x).unwrap();
            let _ = y.permute((0, 2, 3, 1)).unwrap().contiguous().unwrap();
            best = best.min(t.elapsed().as_secs_f64() * 1e3);
        }
        println!("batch {b}: trunk min {best:.1} ms");
    }
    let (_, hm) = seespot_policy::bench::scene(224, 1);
    let mut best = f64::MAX;
    for _ in 0..5 {
        let t = Instant::now();
        let input = seespot_policy::input::NetInput::from_heightmaps(&hm);
        let r: Vec<usize> = (0..16).collect();
        let _ = seespot_policy::rotation::rotate_input_batch(&input, &r);
        best = best.min(t.elapsed().as_secs_f64() * 1e3);
    }
    println!("resample+rotate 224: {best:.1} ms");
    let policy = seespot_policy::PolicyNet::new(seespot_sim::TaskId::Stack, 112, 0).unwrap();
    for res in [224usize, 112] {
        let (_, hm) = seespot_policy::bench::scene(res, 1);
        for what in ["rotated_features", "q_values", "embed"] {
            let mut best = f64::MAX;
            for _ in 0..6 {
                let t = Instant::now();
                match what {
                    "rotated_features" => {
                        policy
                            .rotated_features(&hm, seespot_sim::Primitive::Grasp)
                            .unwrap();
                    }
                    "q_values" => {
                        policy.q_values(&hm, seespot_sim::Primitive::Grasp).unwrap();
                    }
                    _ => {
                        policy.embed(&hm, seespot_sim::Primitive::Grasp).unwrap();
                    }
                }
                best = best.min(t.elapsed().as_secs_f64() * 1e3);
            }
            println!("{res} {what}: {best:.1} ms");
        }
    }
}
