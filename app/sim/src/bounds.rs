//! The one table of every numeric command-line range: each count a command
//! takes has an inclusive range here, which the command line checks with
//! clap's ranged parser (`clap::builder::RangedU64ValueParser::from(range)`)
//! and files with [`check`], so the allowed ranges are written once. The
//! heightmap resolution, which scene files and model files carry too, is
//! checked by [`check_resolution`] (re-exported by [`crate::scene`]); seed
//! ranges by [`crate::Seeds::new`].
//!
//! Errors state the value and the allowed range; clap puts the flag's name in
//! front (`invalid value '0' for '--actions <ACTIONS>': 0 is not in
//! 1..=100000`).
//!
//! ```
//! use seespot_sim::bounds::{self, TRIALS};
//! assert_eq!(bounds::check(TRIALS, 50), Ok(50));
//! assert!(bounds::check(TRIALS, 0).is_err());
//! ```

use std::ops::RangeInclusive;

/// `value` if `range` holds it, else a message naming the range: for counts
/// read from files (a scene's `seeds.count`). The command line checks the
/// same ranges with clap's ranged parsers
/// (`clap::builder::RangedU64ValueParser::from(range)`).
pub fn check(range: RangeInclusive<u64>, value: u64) -> Result<u64, String> {
    if range.contains(&value) {
        Ok(value)
    } else {
        Err(format!(
            "{value} is out of range ({}..={})",
            range.start(),
            range.end()
        ))
    }
}

/// Trials of one run (`eval`, `sim run`, `record`; a scene's `seeds.count`).
pub const TRIALS: RangeInclusive<u64> = 1..=100_000;

/// Own-task evaluation trials after training (0 skips the evaluation).
pub const EVAL_TRIALS: RangeInclusive<u64> = 0..=100_000;

/// Timed actions of `bench sim` and `bench view`.
pub const BENCH_ACTIONS: RangeInclusive<u64> = 1..=100_000;

/// Timed iterations of `bench policy` and `bench ssr`.
pub const BENCH_ITERATIONS: RangeInclusive<u64> = 1..=10_000;

/// Actions of one training run (`train --actions`) and its checkpoint interval.
pub const TRAIN_ACTIONS: RangeInclusive<u64> = 1..=10_000_000;

/// Actions after which a training trial ends (`train --max-trial-actions`).
pub const TRAIN_TRIAL_ACTIONS: RangeInclusive<u64> = 1..=1000;

/// Experiences per primitive a training run's replay keeps (`train
/// --replay-capacity`).
pub const REPLAY_CAPACITY: RangeInclusive<u64> = 1..=1_000_000;

/// Finetuning steps per policy (`eval --finetune-steps`; 0: no finetuning).
pub const FINETUNE_STEPS: RangeInclusive<u64> = 0..=1_000_000;

/// Largest Gaussian smoothing sigma of the distance maps, pixels.
pub const MAX_SMOOTH_SIGMA: f32 = 20.0;

/// A smoothing sigma in pixels: finite, in `0..=`[`MAX_SMOOTH_SIGMA`] (NaN and
/// 1e9, which allocated a 24 GB kernel, are refused).
pub fn parse_sigma(text: &str) -> Result<f32, String> {
    let v: f32 = text
        .trim()
        .parse()
        .map_err(|e| format!("`{text}` is not a number: {e}"))?;
    if v.is_finite() && (0.0..=MAX_SMOOTH_SIGMA).contains(&v) {
        Ok(v)
    } else {
        Err(format!(
            "{text} is out of range (0..={MAX_SMOOTH_SIGMA} pixels)"
        ))
    }
}

/// Smallest and largest heightmap resolution a scene, a model or a command may ask for, pixels.
pub const RESOLUTION_RANGE: std::ops::RangeInclusive<usize> = 32..=448;

/// The one check of a heightmap resolution (scene files, every command's
/// `--resolution`): a multiple of 8 in [`RESOLUTION_RANGE`].
pub fn check_resolution(resolution: usize) -> Result<usize, String> {
    if RESOLUTION_RANGE.contains(&resolution) && resolution.is_multiple_of(8) {
        Ok(resolution)
    } else {
        Err(format!(
            "{resolution} is out of range (a multiple of 8 in 32..=448 pixels)"
        ))
    }
}

/// [`check_resolution`] of a command-line value.
pub fn parse_resolution(text: &str) -> Result<usize, String> {
    let r: usize = text.parse().map_err(|_| {
        format!("`{text}` is not a whole number of pixels (a multiple of 8 in 32..=448)")
    })?;
    check_resolution(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn check_names_the_range() {
        assert_eq!(check(TRIALS, 50), Ok(50));
        let e = check(TRIALS, 0).expect_err("0 trials");
        assert!(e.contains("1..=100000"), "{e}");
        assert_eq!(check(EVAL_TRIALS, 0), Ok(0));
    }

    #[test]
    fn a_misspelt_choice_is_offered_the_nearest_name() {
        let names = ["oracle", "random"];
        assert_eq!(nearest("orcale", names), Some("oracle"));
        assert_eq!(nearest("Random", names), Some("random"));
        assert_eq!(nearest("transporter", names), None);
        let e = parse_named("ssr-cdd", &["ssr-ccd", "ssr-l2cd"], |n| n, "method")
            .expect_err("misspelt");
        assert!(e.contains("did you mean `ssr-ccd`?"), "{e}");
    }

    #[test]
    fn sigma_is_finite_and_bounded() {
        assert_eq!(parse_sigma("3"), Ok(3.0));
        for bad in ["NaN", "inf", "-1", "1e9", "x"] {
            assert!(parse_sigma(bad).is_err(), "{bad}");
        }
    }
}

/// The largest file of each kind seespot reads: a file past its bound is
/// refused with its path and the bound named, before it is held in memory
/// (`view --replay /dev/zero` used to allocate until it aborted).
pub mod files {
    /// A JSONL file of trial records (50 trials take about 0.5 MB).
    pub const RECORDS: u64 = 64 << 20;
    /// A scene file (TOML).
    pub const SCENE: u64 = 1 << 20;
    /// A demonstration's `meta.json`.
    pub const DEMO_META: u64 = 16 << 20;
    /// A weights file (the largest shipped is 1 MB).
    pub const WEIGHTS: u64 = 256 << 20;
    /// A training run's state (about 120 bytes per action: 40 000 actions
    /// take 5 MB).
    pub const TRAIN_STATE: u64 = 1 << 30;
    /// An evaluation lock file.
    pub const LOCK: u64 = 64 << 10;
    /// An ONNX embedding model (the shipped trunk exported is 0.3 MB).
    pub const EMBEDDING_MODEL: u64 = 256 << 20;
    /// A file whose checksum a record carries (a model or a demonstration file).
    pub const CHECKSUMMED: u64 = 256 << 20;
}

/// Reads `path` whole if it holds at most `max` bytes; a longer file (or an
/// endless one such as `/dev/zero`) is an [`std::io::ErrorKind::FileTooLarge`]
/// error stating the bound, read no further than one byte past it. Callers
/// put the path in front, as for any read error.
pub fn read_file(path: &std::path::Path, max: u64) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let file = std::fs::File::open(path)?;
    let meta = file.metadata()?;
    if meta.is_file() && meta.len() > max {
        return Err(too_large(max));
    }
    let mut buf = Vec::new();
    file.take(max + 1).read_to_end(&mut buf)?;
    if buf.len() as u64 > max {
        return Err(too_large(max));
    }
    Ok(buf)
}

/// [`read_file`] as UTF-8 text.
pub fn read_text(path: &std::path::Path, max: u64) -> std::io::Result<String> {
    String::from_utf8(read_file(path, max)?)
        .map_err(|e| std::io::Error::new(std::io::ErrorKind::InvalidData, e))
}

/// The error of a file past its bound.
pub fn too_large(max: u64) -> std::io::Error {
    std::io::Error::new(
        std::io::ErrorKind::FileTooLarge,
        format!(
            "larger than {}, the most seespot reads from a file of this kind",
            human_bytes(max)
        ),
    )
}

fn human_bytes(n: u64) -> String {
    match n {
        n if n >= 1 << 30 && n % (1 << 30) == 0 => format!("{} GiB", n >> 30),
        n if n >= 1 << 20 && n % (1 << 20) == 0 => format!("{} MiB", n >> 20),
        n if n >= 1 << 10 && n % (1 << 10) == 0 => format!("{} KiB", n >> 10),
        n => format!("{n} bytes"),
    }
}

/// A named choice's `as_str` and `FromStr`, from its strum derives
/// (`strum::IntoStaticStr` and `strum::VariantArray`, with the names its
/// `#[strum(...)]` attributes give): the name records and the command line
/// use, and parsing with an error that names `what` was looked for and the
/// choices ([`parse_named`]).
#[macro_export]
macro_rules! named_choice {
    ($t:ty, $what:literal) => {
        impl $t {
            /// The choice's name, as records and the command line spell it.
            pub fn as_str(self) -> &'static str {
                self.into()
            }
        }

        impl std::str::FromStr for $t {
            type Err = String;

            fn from_str(s: &str) -> Result<Self, String> {
                $crate::bounds::parse_named(
                    s,
                    <$t as strum::VariantArray>::VARIANTS,
                    |v| v.into(),
                    $what,
                )
            }
        }
    };
}

/// The one of `all` called `s` by `name`, or an error that names `what` was
/// looked for and the choices (a named setting's `FromStr`).
pub fn parse_named<T: Copy>(
    s: &str,
    all: &[T],
    name: fn(T) -> &'static str,
    what: &str,
) -> Result<T, String> {
    all.iter().copied().find(|c| name(*c) == s).ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|c| name(*c)).collect();
        format!(
            "unknown {what} '{s}'{} (expected {})",
            did_you_mean(s, names.iter().copied()),
            names.join(" or ")
        )
    })
}

/// The one of `names` nearest to `s` (a misspelt choice): fewest single-letter
/// edits, case ignored, within a third of the name's length (at least 2);
/// `None` when none is that near.
pub fn nearest<'a>(s: &str, names: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    let s = s.to_lowercase();
    names
        .into_iter()
        .map(|n| (edits(&s, &n.to_lowercase()), n))
        .filter(|(d, n)| *d <= (n.chars().count() / 3).max(2))
        .min_by_key(|(d, _)| *d)
        .map(|(_, n)| n)
}

/// `"; did you mean `NAME`?"` for the [`nearest`] name, or nothing.
pub fn did_you_mean<'a>(s: &str, names: impl IntoIterator<Item = &'a str>) -> String {
    nearest(s, names).map_or_else(String::new, |n| format!("; did you mean `{n}`?"))
}

/// Levenshtein distance (insertions, deletions, substitutions) with a swap of
/// two neighbouring letters counted as one edit.
fn edits(a: &str, b: &str) -> usize {
    let (a, b): (Vec<char>, Vec<char>) = (a.chars().collect(), b.chars().collect());
    // d[i][j]: edits between a[..i] and b[..j].
    let mut d = vec![vec![0usize; b.len() + 1]; a.len() + 1];
    for (i, row) in d.iter_mut().enumerate() {
        row[0] = i;
    }
    for (j, cell) in d[0].iter_mut().enumerate() {
        *cell = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut best = (d[i - 1][j] + 1)
                .min(d[i][j - 1] + 1)
                .min(d[i - 1][j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                best = best.min(d[i - 2][j - 2] + 1);
            }
            d[i][j] = best;
        }
    }
    d[a.len()][b.len()]
}
