//! Which vector instruction set the path tracer's lane kernels (packet traversal, vector
//! bounce, Sobol runs) use: the widest this CPU has, detected once.
//!
//! `LUMO_SIMD=avx2` (or `baseline`) in the environment caps it, so the narrower forms can be
//! timed on a machine that has wider ones. Every form computes the same bits (tested), so the
//! cap changes speed only. The 8-wide BVH itself needs AVX2 + FMA; `LUMO_BVH_WIDTH=4`
//! ([`crate::accel::blas`]) replaces it with the SSE form.

/// 2 = AVX-512 F/VL, 1 = AVX2, 0 = baseline x86-64 (always 0 on other architectures).
pub(crate) fn simd_level() -> u8 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::sync::OnceLock;
        static LEVEL: OnceLock<u8> = OnceLock::new();
        *LEVEL.get_or_init(|| {
            let detected = if std::is_x86_feature_detected!("avx512f")
                && std::is_x86_feature_detected!("avx512vl")
            {
                2
            } else if std::is_x86_feature_detected!("avx2") {
                1
            } else {
                0
            };
            detected.min(cap(std::env::var("LUMO_SIMD").ok().as_deref()))
        })
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        0
    }
}

/// The level `LUMO_SIMD`'s value allows (no value or an unknown one: no cap).
fn cap(value: Option<&str>) -> u8 {
    match value.map(|v| v.trim().to_ascii_lowercase()).as_deref() {
        Some("avx2") => 1,
        Some("baseline" | "none" | "sse2") => 0,
        _ => u8::MAX,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_environment_caps_the_level() {
        assert_eq!(cap(Some("avx2")), 1);
        assert_eq!(cap(Some(" AVX2 ")), 1);
        assert_eq!(cap(Some("baseline")), 0);
        assert_eq!(cap(Some("avx512")), u8::MAX);
        assert_eq!(cap(None), u8::MAX);
        assert!(simd_level() <= 2);
    }
}
