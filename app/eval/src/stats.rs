//! Paired comparison of two methods on the same seeds: the exact McNemar test
//! (a two-sided binomial test on the discordant pairs).

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use seespot_sim::TrialRecord;
use seespot_sim::task::TaskId;

/// Two methods' outcomes on the seeds both ran.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Paired {
    /// Seeds both methods ran (per task, pooled over tasks for a pooled test).
    pub pairs: usize,
    /// Trials the first method succeeded and the second failed.
    pub only_a: usize,
    /// Trials the second method succeeded and the first failed.
    pub only_b: usize,
    /// Exact two-sided McNemar p-value: `min(1, 2 P(X <= min(only_a, only_b)))`
    /// for `X ~ Binomial(only_a + only_b, 1/2)`; 1 with no discordant pair.
    pub p_value: f64,
}

/// A p-value as the tables print it: three decimals, `< 0.001` below that.
pub fn p_text(p: f64) -> String {
    if p < 0.001 {
        "< 0.001".into()
    } else {
        format!("{p:.3}")
    }
}

/// The exact two-sided McNemar p-value of `b` and `c` discordant pairs.
pub fn mcnemar_exact(b: usize, c: usize) -> f64 {
    let n = b + c;
    if n == 0 {
        return 1.0;
    }
    let k = b.min(c);
    // P(X <= k), X ~ Bin(n, 1/2), summed in log space for large n.
    let ln_half_n = -(n as f64) * std::f64::consts::LN_2;
    let mut ln_choose = 0.0f64; // ln C(n, 0)
    let mut tail = 0.0f64;
    for i in 0..=k {
        if i > 0 {
            ln_choose += ((n - i + 1) as f64).ln() - (i as f64).ln();
        }
        tail += (ln_choose + ln_half_n).exp();
    }
    (2.0 * tail).min(1.0)
}

/// Pairs the records of two methods by (task, seed) — restricted to `task`
/// when given — and tests whether their success differs.
pub fn paired_success(a: &[TrialRecord], b: &[TrialRecord], task: Option<TaskId>) -> Paired {
    let keep = |r: &&TrialRecord| task.is_none_or(|t| r.task == t);
    let outcome: BTreeMap<(TaskId, u64), bool> = a
        .iter()
        .filter(keep)
        .map(|r| ((r.task, r.seed), r.success))
        .collect();
    let (mut pairs, mut only_a, mut only_b) = (0, 0, 0);
    for r in b.iter().filter(keep) {
        if let Some(&sa) = outcome.get(&(r.task, r.seed)) {
            pairs += 1;
            match (sa, r.success) {
                (true, false) => only_a += 1,
                (false, true) => only_b += 1,
                _ => {}
            }
        }
    }
    Paired {
        pairs,
        only_a,
        only_b,
        p_value: mcnemar_exact(only_a, only_b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::records::tests::example;

    #[test]
    fn exact_mcnemar_matches_the_binomial_tail() {
        assert_eq!(mcnemar_exact(0, 0), 1.0);
        // 2 * (1/2)^5 = 0.0625 for 5 vs 0.
        assert!((mcnemar_exact(5, 0) - 0.0625).abs() < 1e-12);
        // 15 vs 11: 2 * P(X <= 11), X ~ Bin(26, 1/2) = 0.5572...
        assert!((mcnemar_exact(15, 11) - 0.557_197_093_963_623).abs() < 1e-9);
        assert_eq!(mcnemar_exact(3, 3), 1.0);
        // Large n stays finite and symmetric.
        let p = mcnemar_exact(600, 500);
        assert!(p > 0.0 && p < 0.01 && (p - mcnemar_exact(500, 600)).abs() < 1e-15);
    }

    #[test]
    fn records_pair_by_task_and_seed() {
        let a: Vec<TrialRecord> = (0..4).map(|k| example(k, k < 3, 6, 4, false)).collect();
        let mut b: Vec<TrialRecord> = (1..5).map(|k| example(k, k == 4, 6, 4, false)).collect();
        b[0].method = "ssr-l2cd".into();
        let p = paired_success(&a, &b, Some(TaskId::Stack));
        // Seeds of trials 1, 2, 3 are shared: a wins 1 and 2, both fail 3.
        assert_eq!((p.pairs, p.only_a, p.only_b), (3, 2, 0));
        assert!((p.p_value - 0.5).abs() < 1e-12);
        assert_eq!(paired_success(&a, &b, Some(TaskId::Row)).pairs, 0);
    }
}
