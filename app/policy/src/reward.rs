//! SPOT rewards (Good Robot!, RA-L 2020): progress-scaled step rewards and the
//! SPOT trial reward that propagates value backwards through a trial.

/// Discount of the SPOT trial reward.
pub const DISCOUNT: f32 = 0.65;

/// The step reward of one executed action, scaled by progress (`P / 4`).
///
/// - a grasp that catches a block without a progress reversal: `P_after / 4`;
/// - a place that releases the block so that progress is higher than it was
///   before the grasp that picked the block up (`progress_before_pair`), without
///   a reversal: `P_after / 4`. Comparing with the grasp's start makes the rule
///   work for unstack, where the grasp (not the place) raises progress and
///   putting the block back on the tower must not pay;
/// - anything else (a failed action, a place that does not help, a reversal): 0.
pub fn step_reward(
    grasp: bool,
    success: bool,
    reversal: bool,
    progress_after: u8,
    progress_before_pair: u8,
) -> f32 {
    if !success || reversal {
        return 0.0;
    }
    let scaled = progress_after as f32 / 4.0;
    if grasp || progress_after > progress_before_pair {
        scaled
    } else {
        0.0
    }
}

/// The SPOT trial reward: `R_i = r_i + DISCOUNT * R_{i+1}`, with `R_i = 0` where
/// `r_i = 0` (an action that did not help gets no credit for what followed), and
/// the last action's `R = last_weight * r` (seespot counts it once; the
/// reference trainer twice).
pub fn trial_rewards(rewards: &[f32], last_weight: f32) -> Vec<f32> {
    let mut out = vec![0.0; rewards.len()];
    // Seeds the propagation so that the last action's R is `last_weight * r`.
    let mut next = rewards
        .last()
        .map_or(0.0, |r| (last_weight - 1.0) * r / DISCOUNT);
    for i in (0..rewards.len()).rev() {
        out[i] = if rewards[i] == 0.0 {
            0.0
        } else {
            rewards[i] + DISCOUNT * next
        };
        next = out[i];
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn trial_reward_propagates_and_zeroes() {
        let r = trial_rewards(&[0.25, 0.0, 0.5, 1.0], 1.0);
        assert_eq!(r[3], 1.0);
        assert!((r[2] - (0.5 + 0.65)).abs() < 1e-6);
        assert_eq!(r[1], 0.0);
        assert_eq!(r[0], 0.25);
    }

    #[test]
    fn reference_trial_reward_counts_the_last_action_twice() {
        let r = trial_rewards(&[0.25, 0.0, 0.5, 1.0], 2.0);
        assert!((r[3] - 2.0).abs() < 1e-6);
        assert!((r[2] - (0.5 + 0.65 * 2.0)).abs() < 1e-6);
        assert_eq!(r[1], 0.0);
        assert_eq!(r[0], 0.25);
        // An unrewarded last action stays at zero either way.
        assert_eq!(trial_rewards(&[0.5, 0.0], 2.0), vec![0.5, 0.0]);
        assert!(trial_rewards(&[], 2.0).is_empty());
    }

    #[test]
    fn unstack_place_pays_only_when_the_pair_helped() {
        // Grasped from the tower (1 -> 2), set down on the table (2 -> 2).
        assert_eq!(step_reward(false, true, false, 2, 1), 0.5);
        // Put back on the tower: the pair did not help.
        assert_eq!(step_reward(false, true, false, 1, 1), 0.0);
    }
}
