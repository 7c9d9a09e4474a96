//! The one seed scheme of seespot (as ravens does): training seeds are even,
//! test seeds are odd from 1, and a separate validation range of odd seeds from
//! [`VALIDATION_START`] is for choosing settings, so that nothing is tuned on the
//! test seeds. A run of trials takes every other seed from its start, so it
//! stays inside its split.
//!
//! ```
//! use seespot_sim::seeds::{Seeds, Split};
//! let test = Seeds::of(Split::Test, 3);
//! assert_eq!(test.iter().collect::<Vec<_>>(), vec![1, 3, 5]);
//! let val = Seeds::of(Split::Validation, 2);
//! assert_eq!(val.iter().collect::<Vec<_>>(), vec![10_001, 10_003]);
//! assert!(Seeds::new(2, 5).is_ok()); // training seeds 2, 4, ..., 10
//! assert!(Seeds::new(9_999, 2).is_err()); // would run from test into validation
//! ```

use serde::{Deserialize, Serialize};

/// The first validation seed; test seeds are the odd seeds below it.
pub const VALIDATION_START: u64 = 10_001;

/// Seeds between two trials of one run (every other seed keeps the parity).
pub const SEED_STEP: u64 = 2;

/// Which purpose a seed serves.
#[derive(
    Clone,
    Copy,
    Debug,
    PartialEq,
    Eq,
    Hash,
    Serialize,
    Deserialize,
    strum::IntoStaticStr,
    strum::VariantArray,
)]
#[serde(rename_all = "kebab-case")]
#[strum(serialize_all = "kebab-case")]
pub enum Split {
    /// Even seeds: training trials and the recorded demonstrations.
    Train,
    /// Odd seeds `1..VALIDATION_START`: the reported test trials.
    Test,
    /// Odd seeds from `VALIDATION_START`: for choosing settings.
    Validation,
}

impl Split {
    /// The split a seed belongs to.
    pub fn of(seed: u64) -> Self {
        if seed.is_multiple_of(2) {
            Self::Train
        } else if seed < VALIDATION_START {
            Self::Test
        } else {
            Self::Validation
        }
    }

    /// The first seed of the split.
    pub fn first(self) -> u64 {
        match self {
            Self::Train => 0,
            Self::Test => 1,
            Self::Validation => VALIDATION_START,
        }
    }
}

crate::named_choice!(Split, "split");

impl std::fmt::Display for Split {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Why a seed range was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SeedError {
    #[error("{count} trials from seed {start} run past the largest seed")]
    Overflow { start: u64, count: u64 },
    #[error(
        "{count} trials from seed {start} leave the {split} seeds (last seed {last} is a {other} seed); test seeds are odd below {VALIDATION_START}"
    )]
    CrossesSplit {
        start: u64,
        count: u64,
        last: u64,
        split: Split,
        other: Split,
    },
}

/// The seeds of one run: `start, start + 2, ..., start + 2 (count - 1)`, all in
/// the split of `start`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Seeds {
    start: u64,
    count: u64,
}

impl Seeds {
    /// `count` seeds from `start`; refused when the last one overflows or falls
    /// in another split than `start`.
    pub fn new(start: u64, count: u64) -> Result<Self, SeedError> {
        if count > 0 {
            let last = count
                .checked_sub(1)
                .and_then(|k| k.checked_mul(SEED_STEP))
                .and_then(|d| start.checked_add(d))
                .ok_or(SeedError::Overflow { start, count })?;
            let (split, other) = (Split::of(start), Split::of(last));
            if split != other {
                return Err(SeedError::CrossesSplit {
                    start,
                    count,
                    last,
                    split,
                    other,
                });
            }
        }
        Ok(Self { start, count })
    }

    /// The first `count` seeds of `split`.
    ///
    /// # Panics
    /// When `count` test seeds would run into the validation range (more than
    /// 5000) or validation seeds past `u64::MAX`; use [`Seeds::new`] for counts
    /// that come from users.
    pub fn of(split: Split, count: u64) -> Self {
        match Self::new(split.first(), count) {
            Ok(s) => s,
            Err(e) => panic!("{e}"),
        }
    }

    pub fn start(&self) -> u64 {
        self.start
    }

    pub fn count(&self) -> u64 {
        self.count
    }

    pub fn split(&self) -> Split {
        Split::of(self.start)
    }

    /// The seed of trial `k` (`None` past the end).
    pub fn get(&self, k: u64) -> Option<u64> {
        (k < self.count).then(|| self.start + SEED_STEP * k)
    }

    /// Whether `seed` is one of these seeds.
    pub fn contains(&self, seed: u64) -> bool {
        seed >= self.start
            && (seed - self.start).is_multiple_of(SEED_STEP)
            && (seed - self.start) / SEED_STEP < self.count
    }

    /// The trial index of `seed`, when it is one of these seeds.
    pub fn index_of(&self, seed: u64) -> Option<u64> {
        self.contains(seed).then(|| (seed - self.start) / SEED_STEP)
    }

    /// The seeds in order (lazy: no list is allocated).
    pub fn iter(&self) -> impl Iterator<Item = u64> + use<> {
        let (start, count) = (self.start, self.count);
        (0..count).map(move |k| start + SEED_STEP * k)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splits_are_disjoint_and_runs_stay_inside_them() {
        assert_eq!(Split::of(0), Split::Train);
        assert_eq!(Split::of(1), Split::Test);
        assert_eq!(Split::of(9_999), Split::Test);
        assert_eq!(Split::of(VALIDATION_START), Split::Validation);
        let test = Seeds::of(Split::Test, 5000);
        assert_eq!(test.iter().last(), Some(9_999));
        assert!(Seeds::new(1, 5001).is_err());
        assert!(Seeds::new(u64::MAX, 2).is_err());
        assert!(Seeds::new(u64::MAX, 1).is_ok());
        assert_eq!(
            Seeds::new(3, u64::MAX),
            Err(SeedError::Overflow {
                start: 3,
                count: u64::MAX
            })
        );
        let s = Seeds::new(101, 3).expect("valid");
        assert_eq!(s.iter().collect::<Vec<_>>(), vec![101, 103, 105]);
        assert_eq!(s.index_of(105), Some(2));
        assert_eq!(s.index_of(107), None);
        assert_eq!(s.index_of(104), None);
        assert_eq!(s.index_of(1), None);
        assert_eq!(Seeds::new(7, 0).map(|s| s.iter().count()), Ok(0));
    }
}
