//! BSDFs at a shading point, in the local frame (z = shading normal). `wo` points towards the
//! viewer, `wi` towards the light; both unit vectors. Values returned by `eval` include the
//! cosine factor |cos θi|, and sample weights are eval / pdf.
//!
//! One file per material (its parameters, `eval`, `pdf`, `sample` and what it reports as albedo
//! or delta); [`Bsdf`] dispatches to them and applies what all opaque materials share (they are
//! two-sided: a viewer behind the surface sees the mirrored configuration).

mod coat;
mod conductor;
mod dielectric;
mod diffuse;
mod fresnel;
mod gltf_pbr;
mod microfacet;
mod mirror;
mod plastic;
mod thin_dielectric;

pub use coat::RoughCoat;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use fresnel::{fresnel_conductor, fresnel_dielectric, fresnel_diffuse_reflectance};
pub use gltf_pbr::GltfPbr;
pub use microfacet::{Distribution, Microfacet};
pub use mirror::Mirror;
pub use plastic::Plastic;
pub use thin_dielectric::{thin_dielectric_reflectance, ThinDielectric};

use glam::{Vec2, Vec3};

/// Roughness below which a microfacet BSDF is treated as perfectly smooth (the scene's
/// [`lumo_scene::BsdfFlags`] call such a BSDF specular by the same bound).
pub use lumo_scene::SMOOTH_ALPHA;

/// A BSDF with its textures resolved at one surface point.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    /// Lambertian.
    Diffuse(Diffuse),
    /// Perfect mirror.
    Mirror(Mirror),
    /// Microfacet conductor.
    Conductor(Conductor),
    /// Diffuse base under a dielectric coat.
    Plastic(Plastic),
    /// Dielectric interface.
    Dielectric(Dielectric),
    /// Thin dielectric sheet.
    ThinDielectric(ThinDielectric),
    /// glTF's metallic-roughness material.
    GltfPbr(GltfPbr),
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Direction towards the light, local frame.
    pub wi: Vec3,
    /// eval / pdf (for delta lobes: the lobe's reflectance / transmittance over its probability).
    pub weight: Vec3,
    /// Solid-angle density (for delta lobes: the discrete probability of the lobe).
    pub pdf: f32,
    /// True when the direction came from a Dirac lobe (not reachable by light sampling).
    pub delta: bool,
    /// Relative index crossed (1 for reflection); radiance through a refraction is scaled by
    /// 1/eta², which `weight` already includes.
    pub eta: f32,
}

/// What a path carries, which decides how refraction scales it (Veach 1997, §5.2): radiance is
/// compressed into the smaller solid angle of the denser medium (× 1/η² crossing into it),
/// importance is not. Camera paths carry radiance; light paths carry importance.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TransportMode {
    /// A path from the camera: the BSDF weights as sampled.
    Radiance,
    /// A path from a light: the adjoint BSDF, without the radiance scaling of refraction.
    Importance,
}

impl BsdfSample {
    /// The sample as a path carrying `mode` sees it: for [`TransportMode::Importance`] the
    /// 1/η² radiance scaling of a refraction (in `weight`) is taken out again.
    #[inline]
    pub fn in_mode(mut self, mode: TransportMode) -> Self {
        if mode == TransportMode::Importance && self.eta != 1.0 {
            self.weight *= self.eta * self.eta;
        }
        self
    }
}

/// The mirror direction of `wo` about the normal, as a delta sample.
#[inline]
fn mirror_sample(wo: Vec3, weight: Vec3, pdf: f32) -> BsdfSample {
    BsdfSample {
        wi: Vec3::new(-wo.x, -wo.y, wo.z),
        weight,
        pdf,
        delta: true,
        eta: 1.0,
    }
}

impl Bsdf {
    /// True if every lobe is a Dirac delta (light sampling is useless there).
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) | Bsdf::Plastic(_) => false,
            Bsdf::Mirror(_) | Bsdf::ThinDielectric(_) => true,
            Bsdf::Conductor(c) => c.is_delta(),
            Bsdf::Dielectric(d) => d.is_delta(),
            Bsdf::GltfPbr(g) => g.is_delta(),
        }
    }

    /// Transmissive BSDFs see both sides as different media; opaque ones are two-sided. The
    /// evaluated counterpart of [`lumo_scene::BsdfSpec::flags`]' `transmission`.
    #[inline]
    pub(crate) fn is_transmissive(&self) -> bool {
        match self {
            Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => true,
            Bsdf::GltfPbr(g) => g.transmission_weight() > 0.0,
            Bsdf::Diffuse(_) | Bsdf::Mirror(_) | Bsdf::Conductor(_) | Bsdf::Plastic(_) => false,
        }
    }

    /// The G-buffer "albedo": diffuse reflectance, or the specular albedo at normal incidence.
    pub fn albedo(&self) -> Vec3 {
        match self {
            Bsdf::Diffuse(d) => d.albedo,
            Bsdf::Mirror(m) => m.reflectance,
            Bsdf::Conductor(c) => c.albedo(),
            Bsdf::Plastic(p) => p.diffuse,
            Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_) => Vec3::ONE,
            Bsdf::GltfPbr(g) => g.albedo(Vec3::Z),
        }
    }

    /// The G-buffer albedo seen from `wo` (local frame): [`Self::albedo`], except for the
    /// plastic, whose coat reflects more towards grazing views (`Plastic::albedo`).
    pub fn albedo_towards(&self, wo: Vec3) -> Vec3 {
        match self {
            Bsdf::Plastic(p) => p.albedo(wo),
            Bsdf::GltfPbr(g) => g.albedo(wo),
            Bsdf::Diffuse(_)
            | Bsdf::Mirror(_)
            | Bsdf::Conductor(_)
            | Bsdf::Dielectric(_)
            | Bsdf::ThinDielectric(_) => self.albedo(),
        }
    }

    /// Opaque BSDFs are two-sided: flip both directions when the viewer is behind the surface.
    #[inline]
    fn orient(&self, wo: Vec3, wi: Vec3) -> (Vec3, Vec3) {
        if !self.is_transmissive() && wo.z < 0.0 {
            (-wo, -wi)
        } else {
            (wo, wi)
        }
    }

    /// f(wo, wi)·|cos θi|.
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let (wo, wi) = self.orient(wo, wi);
        match self {
            Bsdf::Diffuse(d) => d.eval(wo, wi),
            Bsdf::Mirror(_) | Bsdf::ThinDielectric(_) => Vec3::ZERO,
            Bsdf::Conductor(c) => c.eval(wo, wi),
            Bsdf::Plastic(p) => p.eval(wo, wi),
            Bsdf::Dielectric(d) => d.eval(wo, wi),
            Bsdf::GltfPbr(g) => g.eval(wo, wi),
        }
    }

    /// Solid-angle density with which [`Bsdf::sample`] picks `wi` (0 for delta lobes).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (wo, wi) = self.orient(wo, wi);
        match self {
            Bsdf::Diffuse(d) => d.pdf(wo, wi),
            Bsdf::Mirror(_) | Bsdf::ThinDielectric(_) => 0.0,
            Bsdf::Conductor(c) => c.pdf(wo, wi),
            Bsdf::Plastic(p) => p.pdf(wo, wi),
            Bsdf::Dielectric(d) => d.pdf(wo, wi),
            Bsdf::GltfPbr(g) => g.pdf(wo, wi),
        }
    }

    /// Samples `wi` given `wo`, a lobe-selection number and a 2-D point.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let flip = !self.is_transmissive() && wo.z < 0.0;
        let wo_o = if flip { -wo } else { wo };
        let mut s = self.sample_oriented(wo_o, u_lobe, u)?;
        if flip {
            s.wi = -s.wi;
        }
        (s.weight.is_finite() && s.pdf > 0.0).then_some(s)
    }

    /// [`Bsdf::sample`] with an opaque BSDF's `wo` above the surface.
    fn sample_oriented(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        match self {
            Bsdf::Diffuse(d) => Some(d.sample(u)),
            Bsdf::Mirror(m) => Some(mirror_sample(wo, m.reflectance, 1.0)),
            Bsdf::ThinDielectric(t) => Some(t.sample(wo, u_lobe)),
            Bsdf::Conductor(c) => c.sample(wo, u),
            Bsdf::Plastic(p) => p.sample(wo, u_lobe, u),
            Bsdf::Dielectric(d) => d.sample(wo, u_lobe, u),
            Bsdf::GltfPbr(g) => g.sample(wo, u_lobe, u),
        }
    }
}
