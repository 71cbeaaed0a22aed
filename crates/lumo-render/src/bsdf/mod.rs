//! BSDFs at a shading point, in the local frame (z = shading normal). `wo` points towards the
//! viewer, `wi` towards the light; both unit vectors. Values returned by `eval` include the
//! cosine factor |cos θi|, and sample weights are eval / pdf.
//!
//! One file per material: its parameters, `eval`, `pdf`, `sample` and what it reports as albedo
//! or delta, and how it is made from the scene's [`BsdfSpec`] (`at_hit`: textures read at a hit;
//! `at_wavelengths`: its colours at a spectral path's wavelengths). [`Bsdf`] registers each
//! material with one arm per dispatch (every match names every variant) and applies what all
//! opaque materials share (they are two-sided: a viewer behind the surface sees the mirrored
//! configuration). Nothing else in the renderer matches on materials.

mod coat;
mod conductor;
mod dielectric;
mod diffuse;
mod fresnel;
mod gltf_pbr;
mod microfacet;
mod mirror;
mod plastic;
mod principled;
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
pub use principled::Principled;
pub use thin_dielectric::{thin_dielectric_reflectance, ThinDielectric};

use glam::{Vec2, Vec3};
use lumo_scene::{BsdfSpec, Texture};
use lumo_spectrum::Wavelengths;

use crate::geometry::Basis;
use crate::shading::BROAD_COAT_ALPHA;

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
    /// Mitsuba 3's principled (Disney) BSDF.
    Principled(Principled),
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

/// What a material's BSDF sets up once, when the render scene is built, rather than at every
/// hit ([`Prepared::of`]).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Prepared {
    /// A plastic's internal diffuse reflectance of its coat (0 for other materials).
    pub fdr_int: f32,
    /// A rough plastic's tabulated coat, where its scene asks for Mitsuba's exact one.
    pub coat: Option<&'static RoughCoat>,
}

impl Prepared {
    /// The set-up of the BSDF under `spec`'s adapters.
    pub(crate) fn of(spec: &BsdfSpec) -> Self {
        match spec.innermost() {
            BsdfSpec::Plastic {
                ior,
                roughness,
                exact_rough_coat,
                ..
            } => Plastic::prepare(*ior, roughness, *exact_rough_coat),
            // Adapters are not innermost, and two-branch materials' branches are materials of
            // their own.
            BsdfSpec::Diffuse { .. }
            | BsdfSpec::GltfPbr { .. }
            | BsdfSpec::Principled(_)
            | BsdfSpec::Mirror { .. }
            | BsdfSpec::Conductor { .. }
            | BsdfSpec::Dielectric { .. }
            | BsdfSpec::ThinDielectric { .. }
            | BsdfSpec::TwoSided { .. }
            | BsdfSpec::Blend { .. }
            | BsdfSpec::NormalMap { .. }
            | BsdfSpec::BumpMap { .. }
            | BsdfSpec::Mask { .. } => Self::default(),
        }
    }
}

/// A hit as a material reads its parameters there ([`Bsdf::at_hit`]).
#[derive(Clone, Copy)]
pub(crate) struct SpecHit<'a> {
    /// Texture coordinates.
    pub uv: Vec2,
    /// How wide the lookup's footprint is in uv units, which mip-mapped textures read
    /// ([`Texture::eval_at`]; zero: a point lookup).
    pub footprint: f32,
    /// The surface's vertex colour, which tints base colours.
    pub color: Vec3,
    /// Every material's [`Prepared`], indexed by `material` (read only by materials that
    /// prepare something, so the others pay no lookup).
    pub prepared: &'a [Prepared],
    /// The hit's material.
    pub material: usize,
    /// The shading normal a tangent-space normal map gives the hit, in its (unperturbed)
    /// shading frame (`None`: a flat texel): for lobes with a normal map of their own (glTF's
    /// clearcoatNormalTexture), asked only by materials that have one.
    pub normal_map: &'a dyn Fn(&Texture) -> Option<Vec3>,
}

impl SpecHit<'_> {
    /// `t` at the hit, over its footprint.
    #[inline(always)]
    pub fn texture(&self, t: &Texture) -> Vec3 {
        match t {
            Texture::Constant(c) => *c,
            _ => t.eval_at(self.uv, self.footprint),
        }
    }

    /// `t`'s scalar value (its luminance) at the hit, over its footprint.
    #[inline(always)]
    pub fn scalar(&self, t: &Texture) -> f32 {
        t.eval_1_at(self.uv, self.footprint)
    }

    /// What was prepared for the hit's material.
    #[inline(always)]
    pub fn prepared(&self) -> Prepared {
        self.prepared[self.material]
    }
}

/// A material's colours at a spectral path's wavelengths, as a BSDF asks for them
/// ([`Bsdf::at_wavelengths`]); the render scene answers from the material's tabulated spectra
/// or by upsampling RGB.
pub(crate) trait SpectralColours {
    /// The path's wavelengths.
    fn wavelengths(&self) -> &Wavelengths;
    /// A base reflectance `rgb` (a diffuse or plastic base, a glTF base colour): the material's
    /// tabulated reflectance where the surface adds no colour of its own, else `rgb`
    /// upsampled.
    fn base(&self, rgb: Vec3) -> Vec3;
    /// Any other reflectance `rgb`, upsampled.
    fn reflectance(&self, rgb: Vec3) -> Vec3;
    /// A conductor's measured (η, k) at the wavelengths; `None` where the scene gave RGB.
    fn conductor(&self) -> Option<(Vec3, Vec3)>;
    /// A dispersive glass's change of index at the hero wavelength, which stops the other
    /// wavelengths (their paths would refract elsewhere); `None` for a glass without
    /// dispersion.
    fn dispersion(&mut self) -> Option<f32>;
}

/// `t` at `uv`, with the constant case (most materials) inline rather than a call into the
/// scene crate.
#[inline]
pub(crate) fn texture(t: &Texture, uv: Vec2) -> Vec3 {
    match t {
        Texture::Constant(c) => *c,
        _ => t.eval(uv),
    }
}

impl Bsdf {
    /// The scene's `spec` with its textures read at `hit`. Always inlined into
    /// `RenderScene::bsdf` (measured: the call and the moved result cost ~1 % of a render's
    /// instructions); the rare nested adapter goes through an outlined call.
    #[inline(always)]
    pub(crate) fn at_hit(spec: &BsdfSpec, hit: &SpecHit) -> Bsdf {
        match spec {
            BsdfSpec::Diffuse { reflectance } => Bsdf::Diffuse(Diffuse::at_hit(reflectance, hit)),
            BsdfSpec::Mirror { reflectance } => Bsdf::Mirror(Mirror {
                reflectance: *reflectance,
            }),
            BsdfSpec::Conductor { eta, k, roughness } => {
                Bsdf::Conductor(Conductor::at_hit(*eta, *k, roughness, hit))
            }
            BsdfSpec::Plastic {
                diffuse,
                ior,
                roughness,
                nonlinear,
                ..
            } => Bsdf::Plastic(Plastic::at_hit(diffuse, *ior, roughness, *nonlinear, hit)),
            BsdfSpec::Dielectric { ior, roughness } => {
                Bsdf::Dielectric(Dielectric::at_hit(*ior, roughness, hit))
            }
            BsdfSpec::ThinDielectric { ior } => Bsdf::ThinDielectric(ThinDielectric { eta: *ior }),
            BsdfSpec::GltfPbr {
                base_color,
                metallic_roughness,
                metallic,
                roughness,
                extensions,
            } => Bsdf::GltfPbr(GltfPbr::at_hit(
                base_color,
                metallic_roughness.as_ref(),
                *metallic,
                *roughness,
                extensions.as_deref(),
                hit,
            )),
            BsdfSpec::Principled(p) => Bsdf::Principled(Principled::at_hit(p, hit)),
            // Adapters are unwrapped by `RenderScene::bsdf`; one reached here (nested in a way
            // it does not unwrap) stands for the BSDF it wraps. Two-branch BSDFs are split into
            // materials of their own when the render scene is built, so none reaches here.
            BsdfSpec::NormalMap { nested, .. }
            | BsdfSpec::BumpMap { nested, .. }
            | BsdfSpec::Mask { nested, .. }
            | BsdfSpec::TwoSided { front: nested, .. }
            | BsdfSpec::Blend { first: nested, .. } => Self::nested_at_hit(nested, hit),
        }
    }

    /// [`Bsdf::at_hit`] of an adapter's nested BSDF, out of line so the common case inlines
    /// without recursion.
    #[inline(never)]
    fn nested_at_hit(spec: &BsdfSpec, hit: &SpecHit) -> Bsdf {
        Self::at_hit(spec, hit)
    }

    /// This BSDF seen in `f`, the frame of a normal map's perturbed normal (in the surface's
    /// shading frame): lobes with a shading normal of their own (a glTF clear coat) keep it
    /// where it was, so it is re-expressed in `f`; every other BSDF is unchanged.
    #[inline]
    pub(crate) fn in_perturbed_frame(self, f: &Basis) -> Bsdf {
        match self {
            Bsdf::GltfPbr(g) if g.clearcoat > 0.0 => {
                Bsdf::GltfPbr(g.with_coat_normal(f.to_local(g.coat_normal)))
            }
            b => b,
        }
    }

    /// This BSDF at a spectral path's wavelengths: every colour taken from `c`.
    #[inline]
    pub(crate) fn at_wavelengths(self, c: &mut impl SpectralColours) -> Bsdf {
        match self {
            Bsdf::Diffuse(d) => Bsdf::Diffuse(d.at_wavelengths(c)),
            Bsdf::Plastic(p) => Bsdf::Plastic(p.at_wavelengths(c)),
            Bsdf::Mirror(m) => Bsdf::Mirror(Mirror {
                reflectance: c.reflectance(m.reflectance),
            }),
            Bsdf::Conductor(k) => Bsdf::Conductor(k.at_wavelengths(c)),
            Bsdf::Dielectric(d) => Bsdf::Dielectric(d.at_wavelengths(c)),
            Bsdf::ThinDielectric(t) => Bsdf::ThinDielectric(t),
            Bsdf::GltfPbr(g) => Bsdf::GltfPbr(g.at_wavelengths(c)),
            Bsdf::Principled(p) => Bsdf::Principled(p.at_wavelengths(c)),
        }
    }

    /// Whether every lobe is broad enough for light sampling alone to estimate its direct
    /// light without fireflies: a diffuse surface, or a plastic (or non-metallic, opaque glTF
    /// material) under a coat of α ≥ [`BROAD_COAT_ALPHA`].
    #[inline]
    pub fn all_lobes_broad(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) => true,
            Bsdf::Plastic(p) => p.mf.max_alpha() >= BROAD_COAT_ALPHA,
            Bsdf::GltfPbr(g) => {
                g.metallic == 0.0
                    && g.transmission_weight() == 0.0
                    && g.mf.max_alpha() >= BROAD_COAT_ALPHA
            }
            // GGX of α ≥ 0.001 with sharp lobes at low roughness, and a clear coat.
            Bsdf::Mirror(_)
            | Bsdf::Conductor(_)
            | Bsdf::Dielectric(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::Principled(_) => false,
        }
    }

    /// True if every lobe is a Dirac delta (light sampling is useless there).
    pub fn is_delta(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) | Bsdf::Plastic(_) | Bsdf::Principled(_) => false,
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
            Bsdf::Principled(p) => p.bsdf() > 0.0,
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
            Bsdf::Principled(p) => p.albedo(),
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
            | Bsdf::ThinDielectric(_)
            | Bsdf::Principled(_) => self.albedo(),
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
            Bsdf::Principled(p) => p.eval(wo, wi),
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
            Bsdf::Principled(p) => p.pdf(wo, wi),
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
            Bsdf::Principled(p) => p.sample(wo, u_lobe, u),
        }
    }
}
