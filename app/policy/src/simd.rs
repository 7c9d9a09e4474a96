//! Runs a hot loop in the widest vector instructions the CPU has.
//!
//! The build targets baseline x86-64 (SSE2), so it runs on any machine;
//! [`dispatch!`] checks once per call (a cached flag) for AVX-512 or AVX2
//! and, where the CPU has them, runs its body compiled for them. Only the
//! width of the vectors changes: no fused multiply-add is enabled, and
//! Rust never reassociates float sums, so each lane computes what the
//! baseline computes, in the same order, and the results are identical bit
//! for bit (tests compare the paths where it matters). The one `unsafe`
//! of the workspace is here: calling a function compiled for an instruction
//! set, right after checking that the CPU has it.
//!
//! `SEESPOT_SIMD` caps the instruction set: `baseline`, `avx2` or `avx512`
//! (the default: the widest the CPU has). Trials are the same under every
//! cap (a test runs SSR CCD trials under each and compares the records), so
//! a user's results do not depend on their CPU; the cap is for checking
//! exactly that, and for measuring what the wide paths buy.

/// `acc + v * w`, lane by lane, by value: a multiply and an add, never fused,
/// so every instruction set rounds it alike.
#[inline(always)]
pub(crate) fn mul_add(mut acc: [f32; 16], v: f32, w: &[f32; 16]) -> [f32; 16] {
    for l in 0..16 {
        acc[l] += v * w[l];
    }
    acc
}

/// The instruction sets the hot loops may use.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, strum::IntoStaticStr, strum::EnumString,
)]
#[strum(serialize_all = "lowercase", ascii_case_insensitive)]
pub enum Level {
    /// Baseline x86-64 (SSE2).
    #[strum(to_string = "baseline", serialize = "sse2")]
    Baseline,
    Avx2,
    #[strum(to_string = "avx512", serialize = "avx512f")]
    Avx512,
}

impl Level {
    /// The level's name, as `SEESPOT_SIMD` and benchmarks spell it.
    pub fn as_str(self) -> &'static str {
        self.into()
    }

    /// Parses a `SEESPOT_SIMD` value (any case; `sse2` and `avx512f` too).
    pub fn parse(text: &str) -> Option<Self> {
        text.trim().parse().ok()
    }
}

/// The widest instruction set this CPU has.
pub fn detected() -> Level {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Level::Avx512;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return Level::Avx2;
        }
    }
    Level::Baseline
}

/// The cap `SEESPOT_SIMD` sets (none when unset or empty), or the error of
/// a value that is not one (the `seespot` binary checks it at startup).
pub fn cap_from_env() -> Result<Option<Level>, String> {
    match std::env::var("SEESPOT_SIMD") {
        Ok(v) if !v.trim().is_empty() => Level::parse(&v)
            .map(Some)
            .ok_or_else(|| format!("SEESPOT_SIMD={v:?}: not one of baseline, avx2, avx512")),
        _ => Ok(None),
    }
}

/// The instruction set in use: [`detected`], capped by `SEESPOT_SIMD` (read
/// once). An unknown value is never ignored: the binary refuses it at
/// startup ([`cap_from_env`]), and a library user gets a panic naming it.
pub fn level() -> Level {
    static LEVEL: std::sync::OnceLock<Level> = std::sync::OnceLock::new();
    *LEVEL.get_or_init(|| match cap_from_env() {
        Ok(cap) => detected().min(cap.unwrap_or(Level::Avx512)),
        Err(e) => panic!("{e}"),
    })
}

/// Whether the hot loops run in AVX-512F ([`level`]).
#[inline]
pub fn use_avx512() -> bool {
    level() == Level::Avx512
}

/// Whether the hot loops run in AVX2 ([`level`]; false when AVX-512F runs).
#[inline]
pub fn use_avx2() -> bool {
    level() == Level::Avx2
}

/// Evaluates `$body` (an expression) compiled for AVX-512F where the CPU has
/// it, else for AVX2, else for the baseline. The body's hot calls should be
/// `#[inline(always)]` so they are compiled inside the wider function.
#[macro_export]
macro_rules! simd_dispatch {
    ($body:expr) => {{
        #[cfg(target_arch = "x86_64")]
        {
            #[target_feature(enable = "avx512f")]
            fn wide512<R>(f: impl FnOnce() -> R) -> R {
                f()
            }
            #[target_feature(enable = "avx2")]
            fn wide256<R>(f: impl FnOnce() -> R) -> R {
                f()
            }
            if $crate::simd::use_avx512() {
                // SAFETY: the CPU has AVX-512F (checked just above).
                #[allow(unsafe_code)]
                unsafe {
                    wide512(|| $body)
                }
            } else if $crate::simd::use_avx2() {
                // SAFETY: the CPU has AVX2 (checked just above).
                #[allow(unsafe_code)]
                unsafe {
                    wide256(|| $body)
                }
            } else {
                $body
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            $body
        }
    }};
}

pub use simd_dispatch as dispatch;

/// Defines a kernel once and two functions from it: `fn $lanes(args) -> ret`
/// with the body given (`#[inline(always)]`, the plain code; callable
/// directly, e.g. by a test comparing the baseline build), and `fn
/// $name(args) -> ret`, which runs that body compiled for AVX-512F, AVX2 or
/// the baseline, as [`dispatch!`] does. For kernels too large for the
/// compiler to inline [`dispatch!`]'s closure: here the body is inlined
/// straight into each variant, so it is certain to be compiled for that
/// variant's instructions. The attributes given apply to both functions.
#[macro_export]
macro_rules! simd_kernel {
    ($(#[$meta:meta])* $vis:vis fn $name:ident / $lanes:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        #[inline(always)]
        $vis fn $lanes($($arg: $ty),*) $(-> $ret)? $body

        $(#[$meta])*
        #[doc = ""]
        #[doc = concat!("Runs [`", stringify!($lanes), "`] in the widest vector instructions the CPU has.")]
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f")]
                fn wide512($($arg: $ty),*) $(-> $ret)? {
                    $lanes($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                fn wide256($($arg: $ty),*) $(-> $ret)? {
                    $lanes($($arg),*)
                }
                if $crate::simd::use_avx512() {
                    // SAFETY: the CPU has AVX-512F (checked just above).
                    #[allow(unsafe_code)]
                    unsafe {
                        wide512($($arg),*)
                    }
                } else if $crate::simd::use_avx2() {
                    // SAFETY: the CPU has AVX2 (checked just above).
                    #[allow(unsafe_code)]
                    unsafe {
                        wide256($($arg),*)
                    }
                } else {
                    $lanes($($arg),*)
                }
            }
            #[cfg(not(target_arch = "x86_64"))]
            {
                $lanes($($arg),*)
            }
        }
    };
}

pub use simd_kernel as kernel;

#[cfg(test)]
mod tests {
    use super::Level;

    #[test]
    fn levels_are_named_and_parsed_as_seespot_simd_spells_them() {
        for (level, name) in [
            (Level::Baseline, "baseline"),
            (Level::Avx2, "avx2"),
            (Level::Avx512, "avx512"),
        ] {
            assert_eq!(level.as_str(), name);
            assert_eq!(Level::parse(name), Some(level));
            assert_eq!(
                Level::parse(&format!(" {} ", name.to_uppercase())),
                Some(level)
            );
        }
        assert_eq!(Level::parse("sse2"), Some(Level::Baseline));
        assert_eq!(Level::parse("AVX512F"), Some(Level::Avx512));
        assert_eq!(Level::parse("neon"), None);
    }
}
