//! Mitsuba's BSDF adapters, applied around a shading point's BSDF: normal and bump maps (the
//! nested BSDF seen in a perturbed shading frame, `normalmap` / `bumpmap`) and opacity masks
//! (a straight-through lobe chosen with probability 1 − opacity, `mask`).
//!
//! Directions are in the surface's own shading frame, as for [`Bsdf`]; the adapters move them
//! into the perturbed frame and back. The rules follow Mitsuba 3: a direction must lie on the
//! same side in both frames, the perturbed normal is mirrored about the unperturbed one when
//! the viewer would see it from behind (`flip_invalid_normals`), and the microfacet shadowing
//! term of Estevez et al. 2019 darkens light arriving at grazing angles to the unperturbed
//! surface (`use_shadowing_function`).

use glam::{Vec2, Vec3};

use crate::bsdf::{Bsdf, BsdfSample, TransportMode};
use crate::geometry::Basis;

/// The smallest coat roughness (GGX α; glTF roughness ≈ 0.22) of a plastic whose direct light
/// the direct-light split estimates by light sampling alone: below it the coat's highlight of
/// a small light is too sharp for light samples without MIS.
pub const BROAD_COAT_ALPHA: f32 = 0.05;

/// A shading point's BSDF with the adapters of its material applied.
#[derive(Clone, Copy, Debug)]
pub struct ShadingBsdf {
    /// The BSDF under the adapters.
    pub bsdf: Bsdf,
    /// The perturbed shading normal in the surface's shading frame (`None`: unperturbed).
    normal: Option<Vec3>,
    /// Opacity of a mask in [0, 1] (1: no mask).
    opacity: f32,
    /// Whether the nested BSDF is black from behind. Only consulted under a mask: without one,
    /// the integrator ends a path on the back of a one-sided surface before asking the BSDF;
    /// with one, light still passes straight through there.
    back_black: bool,
    /// No adapter applies (no normal, opacity 1, not black from behind): every call goes
    /// straight to `bsdf`. The adapters' arithmetic would give the same bits (× 1.0); the
    /// early branch keeps the common case small enough to inline (measured −1 % of a
    /// render's instructions on the atrium).
    plain: bool,
}

impl From<Bsdf> for ShadingBsdf {
    fn from(bsdf: Bsdf) -> Self {
        Self::new(bsdf, None, 1.0, false)
    }
}

/// `v` mirrored through the surface plane.
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

/// tan²θ of a unit vector in a local frame.
#[inline]
fn tan2(v: Vec3) -> f32 {
    let c2 = v.z * v.z;
    (1.0 - c2).max(0.0) / c2
}

/// The bump-terminator shadowing factor (Estevez et al. 2019, as Mitsuba 3): light from `w`
/// onto a surface whose normal is tilted to `n` (both in the unperturbed frame).
#[inline]
fn shadow_terminator(n: Vec3, w: Vec3) -> f32 {
    let alpha2 = (0.125 * tan2(n)).min(1.0);
    let f = 2.0 / (1.0 + (1.0 + alpha2 * tan2(w)).sqrt());
    if f.is_finite() {
        f
    } else {
        0.0
    }
}

/// The orthonormal frame around perturbed normal `n` (unit, in the unperturbed frame), its
/// tangent as close as possible to the unperturbed tangent, as Mitsuba's `normalmap`.
pub fn perturbed_frame(n: Vec3) -> Basis {
    match (Vec3::X - n * n.x).try_normalize() {
        Some(s) => Basis {
            s,
            t: n.cross(s),
            n,
        },
        // n along the tangent: any frame around it.
        None => Basis::new(n),
    }
}

impl ShadingBsdf {
    /// `bsdf` under a mask of `opacity` and, with `normal`, a perturbed shading normal (unit,
    /// in the surface's shading frame). `back_black`: the BSDF reflects nothing from behind.
    pub fn new(bsdf: Bsdf, normal: Option<Vec3>, opacity: f32, back_black: bool) -> Self {
        Self {
            bsdf,
            normal,
            opacity,
            back_black,
            plain: normal.is_none() && opacity == 1.0 && !back_black,
        }
    }

    /// True if every lobe is a Dirac delta (a mask's straight-through lobe does not make a
    /// smooth BSDF delta: light sampling still serves its opaque part).
    pub fn is_delta(&self) -> bool {
        self.bsdf.is_delta()
    }

    /// The reflectance of a plain Lambertian BSDF (no adapter), whose value and density
    /// depend only on the two directions' cosines to the shading normal: the bidirectional
    /// integrator's fast path. `None` for every other BSDF.
    #[inline]
    pub fn lambert(&self) -> Option<Vec3> {
        match self.bsdf {
            Bsdf::Diffuse(d) if self.plain => Some(d.albedo),
            _ => None,
        }
    }

    /// Whether every lobe is broad (no Dirac lobe, no adapter): a Lambertian surface or a
    /// plastic (or non-metallic glTF material) under a coat of GGX α ≥ [`BROAD_COAT_ALPHA`],
    /// whose direct light light sampling alone estimates without fireflies (the material's
    /// answer: [`Bsdf::all_lobes_broad`]). The direct-light split of temporal filtering
    /// (`crate::direct_split`) takes only these.
    pub fn all_lobes_broad(&self) -> bool {
        self.plain && self.bsdf.all_lobes_broad()
    }

    /// The G-buffer "albedo" of the nested BSDF.
    pub fn albedo(&self) -> Vec3 {
        self.bsdf.albedo()
    }

    /// Whether the nested part is black for viewer `wo`.
    #[inline]
    fn dark(&self, wo: Vec3) -> bool {
        self.back_black && wo.z <= 0.0
    }

    /// The perturbed frame for viewer `wo` (on the front side, or any side for transmissive
    /// BSDFs): the normal mirrored about the unperturbed one if `wo` would see it from behind.
    #[inline]
    fn frame(n: Vec3, wo: Vec3) -> Basis {
        let n = if wo.z * wo.dot(n) <= 0.0 {
            Vec3::new(-n.x, -n.y, n.z)
        } else {
            n
        };
        perturbed_frame(n)
    }

    /// Whether the nested BSDF is opaque (then it is seen from the front: a two-sided surface
    /// seen from behind is mirrored through its plane, as Mitsuba's `twosided` does).
    #[inline]
    fn opaque(&self) -> bool {
        !self.bsdf.is_transmissive()
    }

    /// `wo`, `wi` (mirrored through the plane when an opaque BSDF is seen from behind) in the
    /// perturbed frame of normal `n`: (frame, wo and wi in it, wi before it), or `None` where
    /// `wi` changes side between the two frames or the viewer is below an opaque perturbed
    /// surface. Shared by `eval` and `pdf` so the two agree on where the BSDF is zero.
    #[inline]
    fn perturbed(&self, n: Vec3, wo: Vec3, wi: Vec3) -> Option<(Basis, Vec3, Vec3, Vec3)> {
        let (wo, wi) = if self.opaque() && wo.z < 0.0 {
            (flip_z(wo), flip_z(wi))
        } else {
            (wo, wi)
        };
        let f = Self::frame(n, wo);
        let (po, pi) = (f.to_local(wo), f.to_local(wi));
        if wi.z * pi.z <= 0.0 || (self.opaque() && po.z <= 0.0) {
            return None;
        }
        Some((f, po, pi, wi))
    }

    /// f(wo, wi)·|cos θi|.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.plain {
            return self.bsdf.eval(wo, wi);
        }
        self.eval_adapted(wo, wi)
    }

    /// [`ShadingBsdf::eval`] through the adapters.
    #[inline(never)]
    fn eval_adapted(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.dark(wo) {
            return Vec3::ZERO;
        }
        let value = match self.normal {
            None => self.bsdf.eval(wo, wi),
            Some(n) => {
                let Some((f, po, pi, wi)) = self.perturbed(n, wo, wi) else {
                    return Vec3::ZERO;
                };
                self.bsdf.in_perturbed_frame(&f).eval(po, pi) * shadow_terminator(f.n, wi)
            }
        };
        value * self.opacity
    }

    /// Solid-angle density with which [`ShadingBsdf::sample`] picks `wi` (0 for delta lobes).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.plain {
            return self.bsdf.pdf(wo, wi);
        }
        self.pdf_adapted(wo, wi)
    }

    /// [`ShadingBsdf::pdf`] through the adapters.
    #[inline(never)]
    fn pdf_adapted(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.dark(wo) {
            return 0.0;
        }
        let pdf = match self.normal {
            None => self.bsdf.pdf(wo, wi),
            Some(n) => {
                let Some((f, po, pi, _)) = self.perturbed(n, wo, wi) else {
                    return 0.0;
                };
                self.bsdf.in_perturbed_frame(&f).pdf(po, pi)
            }
        };
        pdf * self.opacity
    }

    /// [`ShadingBsdf::sample`] for a path carrying `mode` (light paths: importance).
    #[inline]
    pub fn sample_mode(
        &self,
        mode: TransportMode,
        wo: Vec3,
        u_lobe: f32,
        u: Vec2,
    ) -> Option<BsdfSample> {
        self.sample(wo, u_lobe, u).map(|s| s.in_mode(mode))
    }

    /// Samples `wi` given `wo`, a lobe-selection number and a 2-D point (radiance transport).
    #[inline]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if self.plain {
            return self.bsdf.sample(wo, u_lobe, u);
        }
        self.sample_adapted(wo, u_lobe, u)
    }

    /// Whether [`ShadingBsdf::sample`] with this `u_lobe` takes the mask's straight-through
    /// lobe (the same test as there).
    #[inline]
    pub fn passes(&self, u_lobe: f32) -> bool {
        self.opacity < 1.0 && u_lobe >= self.opacity
    }

    /// The mask's opacity at this point (1 without a mask): the probability that light meets
    /// the nested BSDF rather than passing straight through.
    #[inline]
    pub fn opacity(&self) -> f32 {
        self.opacity
    }

    /// [`ShadingBsdf::sample`] through the adapters.
    #[inline(never)]
    fn sample_adapted(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let mut u_lobe = u_lobe;
        if self.opacity < 1.0 {
            // Mitsuba's mask: the nested BSDF below the opacity, straight through above it.
            if u_lobe >= self.opacity {
                return Some(BsdfSample {
                    wi: -wo,
                    weight: Vec3::ONE,
                    pdf: 1.0 - self.opacity,
                    delta: true,
                    eta: 1.0,
                });
            }
            u_lobe /= self.opacity;
        }
        if self.dark(wo) {
            return None;
        }
        let mut s = match self.normal {
            None => self.bsdf.sample(wo, u_lobe, u)?,
            Some(n) => {
                let flip = self.opaque() && wo.z < 0.0;
                let wo = if flip { flip_z(wo) } else { wo };
                let f = Self::frame(n, wo);
                let po = f.to_local(wo);
                if self.opaque() && po.z <= 0.0 {
                    return None;
                }
                let mut s = self.bsdf.in_perturbed_frame(&f).sample(po, u_lobe, u)?;
                let wi = f.to_world(s.wi);
                if wi.z * s.wi.z <= 0.0 {
                    return None;
                }
                s.weight *= shadow_terminator(f.n, wi);
                s.wi = if flip { flip_z(wi) } else { wi };
                s
            }
        };
        s.pdf *= self.opacity;
        Some(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::Diffuse;

    #[test]
    fn perturbed_frames_are_orthonormal() {
        for i in 0..200 {
            let a = i as f32 * 0.731;
            let z = (i as f32 * 0.377).fract() * 2.0 - 1.0;
            let r = (1.0 - z * z).sqrt();
            let n = Vec3::new(r * a.cos(), r * a.sin(), z);
            for wo in [Vec3::Z, Vec3::new(0.6, 0.0, 0.8), Vec3::new(0.0, -0.8, 0.6)] {
                let f = ShadingBsdf::frame(n, wo);
                for (a, b) in [(f.s, f.t), (f.t, f.n), (f.n, f.s)] {
                    assert!(a.dot(b).abs() < 1e-5, "{n}: {a} · {b}");
                }
                for v in [f.s, f.t, f.n] {
                    assert!((v.length() - 1.0).abs() < 1e-5, "{n}: {v}");
                }
                assert!(f.s.cross(f.t).dot(f.n) > 0.99, "{n}: left-handed");
            }
        }
    }

    #[test]
    fn unperturbed_normal_changes_nothing() {
        let bsdf = Bsdf::Diffuse(Diffuse {
            albedo: Vec3::splat(0.7),
        });
        let plain = ShadingBsdf::from(bsdf);
        let mapped = ShadingBsdf::new(bsdf, Some(Vec3::Z), 1.0, false);
        let (wo, wi) = (
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(-0.5, 0.2, 0.7).normalize(),
        );
        assert!(
            (plain.eval(wo, wi) - mapped.eval(wo, wi))
                .abs()
                .max_element()
                < 1e-6
        );
        assert!((plain.pdf(wo, wi) - mapped.pdf(wo, wi)).abs() < 1e-6);
    }

    #[test]
    fn mask_passes_through_with_one_minus_opacity() {
        let bsdf = Bsdf::Diffuse(Diffuse {
            albedo: Vec3::splat(0.5),
        });
        let masked = ShadingBsdf::new(bsdf, None, 0.25, false);
        let wo = Vec3::new(0.2, 0.3, 0.9).normalize();
        let through = masked.sample(wo, 0.6, Vec2::splat(0.5)).unwrap();
        assert_eq!(through.wi, -wo);
        assert!(through.delta && (through.pdf - 0.75).abs() < 1e-6);
        let opaque = masked.sample(wo, 0.1, Vec2::splat(0.5)).unwrap();
        assert!(!opaque.delta && opaque.wi.z > 0.0);
        // Weight unchanged (opacity / opacity), density scaled by the opacity.
        assert!((opaque.weight - Vec3::splat(0.5)).abs().max_element() < 1e-5);
        assert!((opaque.pdf - 0.25 * bsdf.pdf(wo, opaque.wi)).abs() < 1e-6);
        assert!((masked.eval(wo, opaque.wi) - 0.25 * bsdf.eval(wo, opaque.wi)).length() < 1e-6);
    }
}
