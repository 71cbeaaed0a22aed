//! Fresnel reflectance for dielectric and conducting interfaces.

/// Dielectric Fresnel reflectance for a wave arriving with cosine `cos_i` (positive: from the
/// outside) at an interface of relative index `eta` (inside / outside).
///
/// Returns (R, cos_t, eta_it, eta_ti): reflectance, signed cosine of the refracted direction
/// (opposite side to the incident one), and the relative indices of the two media.
#[inline]
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32, f32) {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    let cos_t_sqr = 1.0 - eta_ti * eta_ti * (1.0 - cos_i * cos_i);
    let ci = cos_i.abs();
    let ct = cos_t_sqr.max(0.0).sqrt();
    let a_s = (ci - eta_it * ct) / (ci + eta_it * ct);
    let a_p = (ct - eta_it * ci) / (ct + eta_it * ci);
    let r = if cos_t_sqr <= 0.0 || eta == 1.0 && ci == 0.0 {
        if cos_t_sqr <= 0.0 {
            1.0
        } else {
            0.0
        }
    } else {
        0.5 * (a_s * a_s + a_p * a_p)
    };
    let cos_t = if outside { -ct } else { ct };
    (r, cos_t, eta_it, eta_ti)
}

/// Unpolarised reflectance of a conductor with complex index `eta + i·k` at incidence `cos_i`.
#[inline]
pub fn fresnel_conductor(cos_i: f32, eta: f32, k: f32) -> f32 {
    let c2 = (cos_i * cos_i).min(1.0);
    let s2 = 1.0 - c2;
    let (e2, k2) = (eta * eta, k * k);
    let t0 = e2 - k2 - s2;
    let a2b2 = (t0 * t0 + 4.0 * e2 * k2).max(0.0).sqrt();
    let t1 = a2b2 + c2;
    let a = (0.5 * (a2b2 + t0)).max(0.0).sqrt();
    let t2 = 2.0 * cos_i.abs() * a;
    let rs = (t1 - t2) / (t1 + t2);
    let t3 = c2 * a2b2 + s2 * s2;
    let t4 = t2 * s2;
    let rp = rs * (t3 - t4) / (t3 + t4);
    (0.5 * (rp + rs)).clamp(0.0, 1.0)
}

/// Hemispherical average of the dielectric Fresnel reflectance (cosine-weighted), by quadrature.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let n = 1024;
    let mut sum = 0.0f64;
    for i in 0..n {
        // ∫ F(μ) 2μ dμ over μ = cosθ in (0, 1), midpoint rule.
        let mu = (i as f32 + 0.5) / n as f32;
        sum += (fresnel_dielectric(mu, eta).0 * 2.0 * mu) as f64;
    }
    (sum / n as f64) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_known_values() {
        // Normal incidence: ((η−1)/(η+1))² = 0.04 for glass.
        assert!((fresnel_dielectric(1.0, 1.5).0 - 0.04).abs() < 1e-5);
        // Total internal reflection past the critical angle from inside.
        assert_eq!(fresnel_dielectric(-0.2, 1.5).0, 1.0);
        // Same reflectance seen from both sides at matched angles (Snell pairs).
        let (r, cos_t, _, _) = fresnel_dielectric(0.7, 1.5);
        let (r2, _, _, _) = fresnel_dielectric(cos_t, 1.5);
        assert!((r - r2).abs() < 1e-5);
    }

    #[test]
    fn conductor_limits() {
        // k = 0 reduces to the dielectric formula.
        for c in [0.1f32, 0.5, 0.9, 1.0] {
            let a = fresnel_conductor(c, 1.5, 0.0);
            let b = fresnel_dielectric(c, 1.5).0;
            assert!((a - b).abs() < 1e-4, "{c}: {a} vs {b}");
        }
        assert!(fresnel_conductor(0.0, 0.2, 3.0) > 0.999);
    }

    #[test]
    fn diffuse_reflectance_reciprocity() {
        // 1 − Fdr_int = (1 − Fdr_ext) / η² (energy balance across the interface).
        let eta = 1.5f32;
        let ext = fresnel_diffuse_reflectance(eta);
        let int = fresnel_diffuse_reflectance(1.0 / eta);
        assert!(
            ((1.0 - int) - (1.0 - ext) / (eta * eta)).abs() < 2e-3,
            "{ext} {int}"
        );
    }
}
