//! Runs a hot loop compiled for AVX2 when the CPU has it, else for the
//! x86_64 baseline (SSE2) the crate is built for.
//!
//! Why: the image loops here (box filters, the profile models, the
//! local-extremum scan) are written as plain slice loops that the compiler
//! vectorises; built for the baseline they run 4 f32 lanes, with AVX2 8. A
//! crate-wide `-C target-cpu` would make the binary refuse older CPUs, so the
//! choice is made at run time, once per call (`is_x86_feature_detected!`
//! caches its answer). Only AVX2 is enabled, not FMA: Rust never fuses a
//! multiply and an add on its own, so both versions compute the same bits.
//! Hand-written because it is one macro; the crates that do this bring a
//! proc-macro dependency for the same few lines.

/// `avx2_dispatch!(pub fn name(a: A, b: B) -> R => generic);` defines `name`,
/// which calls `generic` (an `#[inline(always)]` function with the same
/// arguments) compiled with AVX2 enabled when the CPU supports it.
macro_rules! avx2_dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? => $generic:path) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                /// # Safety
                /// The CPU must support AVX2.
                #[target_feature(enable = "avx2")]
                unsafe fn wide($($arg: $ty),*) $(-> $ret)? {
                    $generic($($arg),*)
                }
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: `wide` only needs AVX2, which the CPU was just
                    // checked to support.
                    return unsafe { wide($($arg),*) };
                }
            }
            $generic($($arg),*)
        }
    };
}

pub(crate) use avx2_dispatch;
