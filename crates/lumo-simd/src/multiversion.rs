//! Run-time selection between copies of one function compiled for AVX-512, AVX2 and the
//! baseline instruction set.
//!
//! Why: the workspace builds for baseline x86-64 (SSE2), where the compiler leaves loops over
//! interleaved pixels (RGB, xyz: a stride of 3 or 4 floats) scalar; compiled with AVX2 or
//! AVX-512 it turns them into vector loads and permutes. The copies run the same operations
//! (no fused multiply-adds are formed), so their results are identical bit for bit.

/// Defines `fn $name(args) -> ret { body }` as a dispatcher that runs the body in its AVX-512
/// (F + VL) copy, its AVX2 copy or the baseline one, whichever is the widest [`Isa::detect`]
/// allows (the CPU's best, capped by `LUMO_SIMD`).
///
/// [`Isa::detect`]: crate::Isa::detect
/// The body itself becomes `$imp`, an `#[inline(always)]` function with the same signature,
/// compiled into each copy (and callable directly: the tests compare it with the dispatcher).
#[macro_export]
macro_rules! multiversion {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident $(<$(const $g:ident: $gt:ty),*>)?
            ($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? as $imp:ident $body:block
    ) => {
        #[doc = concat!(
            "The body of [`", stringify!($name), "`], compiled into each of its copies."
        )]
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        $vis fn $imp $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? $body

        $(#[$meta])*
        $vis fn $name $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                /// The AVX-512 copy.
                ///
                /// # Safety
                /// The CPU must support AVX-512F and AVX-512VL.
                #[target_feature(enable = "avx512f,avx512vl,avx2")]
                #[allow(clippy::too_many_arguments)]
                unsafe fn avx512 $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? {
                    $imp $(::<$($g),*>)? ($($arg),*)
                }
                /// The AVX2 copy.
                ///
                /// # Safety
                /// The CPU must support AVX2.
                #[target_feature(enable = "avx2")]
                #[allow(clippy::too_many_arguments)]
                unsafe fn avx2 $(<$(const $g: $gt),*>)? ($($arg: $ty),*) $(-> $ret)? {
                    $imp $(::<$($g),*>)? ($($arg),*)
                }
                match $crate::Isa::detect() {
                    // SAFETY: Isa::detect reports AVX-512 only where F, VL and AVX2 exist.
                    $crate::Isa::Avx512 => return unsafe { avx512 $(::<$($g),*>)? ($($arg),*) },
                    // SAFETY: Isa::detect reports AVX2 only where it exists.
                    $crate::Isa::Avx2 => return unsafe { avx2 $(::<$($g),*>)? ($($arg),*) },
                    $crate::Isa::Baseline => {}
                }
            }
            $imp $(::<$($g),*>)? ($($arg),*)
        }
    };
}
