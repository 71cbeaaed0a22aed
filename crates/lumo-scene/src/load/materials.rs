//! Material conversions several formats share.

use glam::Vec3;

/// A conductor (eta = 1) whose normal-incidence reflectance is `r`: with eta = 1 the Fresnel
/// reflectance at normal incidence is k² / (4 + k²), so k = 2·sqrt(r / (1 − r)).
pub(crate) fn metal_from_reflectance(r: Vec3) -> (Vec3, Vec3) {
    let r = r.clamp(Vec3::ZERO, Vec3::splat(0.999));
    let k = Vec3::new(
        2.0 * (r.x / (1.0 - r.x)).sqrt(),
        2.0 * (r.y / (1.0 - r.y)).sqrt(),
        2.0 * (r.z / (1.0 - r.z)).sqrt(),
    );
    (Vec3::ONE, k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metal_reflectance_round_trips() {
        let (eta, k) = metal_from_reflectance(Vec3::new(0.9, 0.5, 0.1));
        let f0 = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
        assert!(
            (f0 - Vec3::new(0.9, 0.5, 0.1)).abs().max_element() < 1e-5,
            "{f0}"
        );
    }
}
