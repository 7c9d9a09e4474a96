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
            if ::std::arch::is_x86_feature_detected!("avx512f") {
                // SAFETY: the CPU has AVX-512F (checked just above).
                #[allow(unsafe_code)]
                unsafe {
                    wide512(|| $body)
                }
            } else if ::std::arch::is_x86_feature_detected!("avx2") {
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
                if ::std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: the CPU has AVX-512F (checked just above).
                    #[allow(unsafe_code)]
                    unsafe {
                        wide512($($arg),*)
                    }
                } else if ::std::arch::is_x86_feature_detected!("avx2") {
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
