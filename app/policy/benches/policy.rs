//! Criterion benches: Q maps and ASE maps of both primitives for all 16
//! rotations at 224 and 112 px, and one SPOT-Q training step. The report prints
//! ratios against the 112 px forward measured in the same run.

use criterion::{Criterion, criterion_group, criterion_main};
use seespot_policy::PolicyNet;
use seespot_policy::bench::{fixed_batch, scene};
use seespot_policy::trainer::{DEFAULT_BATCH, Learner, LearnerConfig};
use seespot_sim::{Primitive, TaskId};

fn forward(c: &mut Criterion) {
    let policy = PolicyNet::new(TaskId::Stack, 112, 0).expect("policy");
    let mut g = c.benchmark_group("policy");
    g.sample_size(10);
    for res in [224usize, 112] {
        let (_, hm) = scene(res, 1);
        g.bench_function(format!("q_both_primitives_16_rotations_{res}px"), |b| {
            b.iter(|| {
                for p in Primitive::ALL {
                    policy.q_values(&hm, p).expect("q");
                }
            })
        });
        g.bench_function(
            format!("embed_with_q_both_primitives_16_rotations_{res}px"),
            |b| {
                b.iter(|| {
                    for p in Primitive::ALL {
                        policy.embed_with_q(&hm, p).expect("embed");
                    }
                })
            },
        );
    }
    let mut learner = Learner::new(
        PolicyNet::new(TaskId::Stack, 112, 0).expect("policy"),
        LearnerConfig::default(),
    )
    .expect("learner");
    let batch = fixed_batch(DEFAULT_BATCH);
    g.bench_function(format!("train_step_batch_{DEFAULT_BATCH}"), |b| {
        b.iter(|| learner.train_step(&batch).expect("step"))
    });
    g.finish();
}

criterion_group!(benches, forward);
criterion_main!(benches);
