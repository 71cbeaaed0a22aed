//! Instruction-set detection with one vocabulary for every crate.

use std::sync::OnceLock;

/// The vector instruction sets lumo's kernels are compiled for, narrowest first (so `>=`
/// reads "at least").
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Isa {
    /// Baseline x86-64 (SSE2), or any other architecture.
    Baseline,
    /// AVX2 with FMA.
    Avx2,
    /// AVX-512 F and VL, with AVX2 and FMA.
    Avx512,
}

impl Isa {
    /// The widest set this CPU supports and `LUMO_SIMD` allows, detected once.
    pub fn detect() -> Isa {
        static ISA: OnceLock<Isa> = OnceLock::new();
        *ISA.get_or_init(|| {
            Isa::hardware().min(Isa::cap(std::env::var("LUMO_SIMD").ok().as_deref()))
        })
    }

    /// The widest set this CPU supports, whatever `LUMO_SIMD` says: for choices that are not
    /// about speed alone (the 8-wide BVH needs AVX2 + FMA to exist at all).
    pub fn hardware() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            let avx2 =
                std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma");
            if avx2
                && std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx512vl")
            {
                return Isa::Avx512;
            }
            if avx2 {
                return Isa::Avx2;
            }
        }
        Isa::Baseline
    }

    /// Every set up to and including `self`, narrowest first: the forms a test compares.
    pub fn up_to(self) -> Vec<Isa> {
        [Isa::Baseline, Isa::Avx2, Isa::Avx512]
            .into_iter()
            .filter(|&i| i <= self)
            .collect()
    }

    /// The widest set a `LUMO_SIMD` value allows (no value or an unknown one: no cap).
    fn cap(value: Option<&str>) -> Isa {
        match value.map(|v| v.trim().to_ascii_lowercase()).as_deref() {
            Some("avx2") => Isa::Avx2,
            Some("baseline" | "none" | "sse2") => Isa::Baseline,
            _ => Isa::Avx512,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_environment_caps_the_set() {
        assert_eq!(Isa::cap(Some("avx2")), Isa::Avx2);
        assert_eq!(Isa::cap(Some(" AVX2 ")), Isa::Avx2);
        assert_eq!(Isa::cap(Some("baseline")), Isa::Baseline);
        assert_eq!(Isa::cap(Some("avx512")), Isa::Avx512);
        assert_eq!(Isa::cap(None), Isa::Avx512);
        assert!(Isa::detect() <= Isa::hardware());
        assert_eq!(Isa::Avx2.up_to(), vec![Isa::Baseline, Isa::Avx2]);
    }
}
