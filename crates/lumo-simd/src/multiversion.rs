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
///
/// The form `fn $name(args) as $imp, at $at { body }` also defines `$at(level, args)`, which
/// runs the copy for `level` capped at what the CPU runs (`$name` is `$at(Isa::detect(), …)`):
/// tests call it at every level to compare the copies with each other and with scalar code.
#[macro_export]
macro_rules! multiversion {
    // The dispatch both forms share: the AVX-512 and AVX2 copies of `$imp` and the choice
    // among them for `$level` capped at what the CPU runs. `$gen` and `$turbo` are the
    // function's const generics as declared and as passed.
    (@run $level:expr; $imp:ident; [$($gen:tt)*]; [$($turbo:tt)*];
        ($($arg:ident: $ty:ty),*) $(-> $ret:ty)?
    ) => {{
        #[cfg(target_arch = "x86_64")]
        {
            /// The AVX-512 copy.
            ///
            /// # Safety
            /// The CPU must support AVX-512F and AVX-512VL.
            #[target_feature(enable = "avx512f,avx512vl,avx2")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn avx512 $($gen)* ($($arg: $ty),*) $(-> $ret)? {
                $imp $($turbo)* ($($arg),*)
            }
            /// The AVX2 copy.
            ///
            /// # Safety
            /// The CPU must support AVX2.
            #[target_feature(enable = "avx2")]
            #[allow(clippy::too_many_arguments)]
            unsafe fn avx2 $($gen)* ($($arg: $ty),*) $(-> $ret)? {
                $imp $($turbo)* ($($arg),*)
            }
            match $level.min($crate::Isa::detect()) {
                // SAFETY: capped at Isa::detect, which reports AVX-512 only where F, VL and
                // AVX2 exist.
                $crate::Isa::Avx512 => return unsafe { avx512 $($turbo)* ($($arg),*) },
                // SAFETY: capped at Isa::detect, which reports AVX2 only where it exists.
                $crate::Isa::Avx2 => return unsafe { avx2 $($turbo)* ($($arg),*) },
                $crate::Isa::Baseline => {}
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = $level;
        $imp $($turbo)* ($($arg),*)
    }};
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident ($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)?
            as $imp:ident, at $at:ident $body:block
    ) => {
        #[doc = concat!(
            "The body of [`", stringify!($name), "`], compiled into each of its copies."
        )]
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        $vis fn $imp ($($arg: $ty),*) $(-> $ret)? $body

        #[doc = concat!(
            "[`", stringify!($name), "`] in its copy for `level` (at most what this CPU runs)."
        )]
        #[allow(clippy::too_many_arguments)]
        $vis fn $at (level: $crate::Isa, $($arg: $ty),*) $(-> $ret)? {
            $crate::multiversion!(@run level; $imp; []; []; ($($arg: $ty),*) $(-> $ret)?)
        }

        $(#[$meta])*
        #[allow(clippy::too_many_arguments)]
        $vis fn $name ($($arg: $ty),*) $(-> $ret)? {
            $at($crate::Isa::detect(), $($arg),*)
        }
    };
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
            $crate::multiversion!(
                @run $crate::Isa::detect();
                $imp;
                [$(<$(const $g: $gt),*>)?];
                [$(::<$($g),*>)?];
                ($($arg: $ty),*) $(-> $ret)?
            )
        }
    };
}
