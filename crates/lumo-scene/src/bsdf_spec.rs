//! A surface's BSDF as a scene describes it ([`BsdfSpec`]), and what the renderer and the server
//! ask of any of them, answered in one place: which lobes it has (pbrt-v4's `BxDFFlags`), the
//! BSDF under its adapters, its roughness and base colour. Every match here names every variant,
//! so a new BSDF does not compile until it answers them; it is the one scene-side file a new
//! material changes besides its loader.

use std::sync::Arc;

use glam::{Vec2, Vec3};

use crate::material::Roughness;
use crate::Texture;

/// How a surface scatters light, as a scene describes it (parameters may be textures); the
/// renderer turns it into an evaluated `lumo_render::bsdf::Bsdf` at each hit.
#[derive(Clone, Debug)]
pub enum BsdfSpec {
    /// Lambertian reflection.
    Diffuse {
        /// Reflectance (albedo).
        reflectance: Texture,
    },
    /// Perfect specular reflection with a constant reflectance.
    Mirror {
        /// Reflectance.
        reflectance: Vec3,
    },
    /// A metal: microfacets with the exact conductor Fresnel term (α = 0: smooth).
    Conductor {
        /// Real part of the complex index of refraction, per RGB channel.
        eta: Vec3,
        /// Imaginary part (absorption), per RGB channel.
        k: Vec3,
        /// Microfacet distribution and α.
        roughness: Roughness,
    },
    /// A diffuse base under a smooth or rough dielectric coat (Mitsuba's (rough)plastic).
    Plastic {
        /// Reflectance of the diffuse base.
        diffuse: Texture,
        /// Index of refraction of the coat.
        ior: f32,
        /// Microfacet distribution and α of the coat (isotropic, as Mitsuba requires).
        roughness: Roughness,
        /// Mitsuba's `nonlinear`: the base's own colour also tints the light it re-reflects
        /// inside the coat, saturating the colour (default false).
        nonlinear: bool,
        /// Mitsuba's rough coat: the diffuse layer sees the coat's transmittance and internal
        /// reflectance integrated over its microfacets (tabulated when the scene is prepared).
        /// False keeps the smooth coat's Fresnel terms at any roughness, as lumo's built-in,
        /// glTF and OBJ materials do (cheaper to prepare; their images stay as they were).
        exact_rough_coat: bool,
    },
    /// Glass: refraction and reflection at an interface (α = 0: smooth).
    Dielectric {
        /// Interior index of refraction over exterior.
        ior: f32,
        /// Microfacet distribution and α.
        roughness: Roughness,
    },
    /// A thin dielectric sheet (Mitsuba's `thindielectric`): specular reflection and
    /// straight-through transmission, with the bounces inside the sheet summed.
    ThinDielectric {
        /// Index of refraction of the sheet over that of its surroundings.
        ior: f32,
    },
    /// A BSDF whose shading normal is read from a tangent-space normal map (Mitsuba's
    /// `normalmap`): RGB in [0, 1] encodes the normal (x, y, z) relative to the frame of the
    /// tangent ∂p/∂u and the surface normal.
    NormalMap {
        /// The normal map (linear values, as Mitsuba's `raw` bitmap).
        normals: Texture,
        /// The BSDF seen under the perturbed normal.
        nested: Box<BsdfSpec>,
    },
    /// A BSDF whose shading normal is tilted by the gradient of a height texture (Mitsuba's
    /// `bumpmap`).
    BumpMap {
        /// Height, in uv units (its luminance for colour textures).
        height: Texture,
        /// Multiplier of the height (Mitsuba's `scale`).
        scale: f32,
        /// The BSDF seen under the perturbed normal.
        nested: Box<BsdfSpec>,
    },
    /// Mitsuba's `twosided` with two BSDFs: `front` where the ray arrives on the side the
    /// geometric normal points to, `back` on the other side (seen there as from its own
    /// front). Both are opaque (reflection only).
    TwoSided {
        /// The BSDF of the front side.
        front: Box<BsdfSpec>,
        /// The BSDF of the back side.
        back: Box<BsdfSpec>,
    },
    /// Mitsuba's `blendbsdf`: (1 − weight)·first + weight·second. The renderer picks one of
    /// the two at each shading point with those probabilities (an unbiased estimate of the
    /// blend in every integrator).
    Blend {
        /// Weight of `second` in [0, 1] (its luminance for colour textures).
        weight: Texture,
        /// The BSDF weighted by 1 − weight.
        first: Box<BsdfSpec>,
        /// The BSDF weighted by weight.
        second: Box<BsdfSpec>,
    },
    /// glTF 2.0's metallic-roughness material (its Appendix B BRDF), read per texel.
    GltfPbr {
        /// Base colour: baseColorTexture × baseColorFactor (sRGB decoded), or the factor.
        base_color: Texture,
        /// metallicRoughnessTexture (linear): roughness in its green channel, metalness in
        /// its blue one, multiplying the factors below; `None`: the factors alone.
        metallic_roughness: Option<Texture>,
        /// metallicFactor in [0, 1].
        metallic: f32,
        /// roughnessFactor in [0, 1] (perceptual: GGX α is its square).
        roughness: f32,
        /// What the material's KHR_materials_* extensions add; `None`: none used.
        extensions: Option<Arc<crate::GltfExtensions>>,
    },
    /// Mitsuba 3's `principled` BSDF (Burley's Disney BSDF), read per texel.
    Principled(Arc<crate::PrincipledSpec>),
    /// An opacity cut-out (Mitsuba's `mask`, glTF's alphaMode): the nested BSDF with
    /// probability `opacity` × the mesh's vertex alpha, otherwise the ray passes straight
    /// through.
    Mask {
        /// Opacity in [0, 1] (its luminance for colour textures).
        opacity: Texture,
        /// glTF MASK applied at the hit: opaque where opacity × vertex alpha ≥ the cutoff,
        /// absent elsewhere (for meshes with vertex alpha, which no texture can bake in);
        /// `None`: the product itself is the opacity.
        cutoff: Option<f32>,
        /// The BSDF of the opaque part.
        nested: Box<BsdfSpec>,
    },
}

/// α below which a microfacet surface is treated as perfectly smooth (a Dirac lobe).
pub const SMOOTH_ALPHA: f32 = 1e-3;

/// The kinds of lobe a BSDF has (pbrt-v4's `BxDFFlags`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BsdfFlags {
    /// Scatters light back to the side it came from.
    pub reflection: bool,
    /// Lets light through to the other side (refraction, a thin sheet, a mask's holes).
    pub transmission: bool,
    /// Has a Lambertian lobe.
    pub diffuse: bool,
    /// Has a rough microfacet lobe.
    pub glossy: bool,
    /// Has a Dirac lobe (smooth reflection or transmission).
    pub specular: bool,
}

impl BsdfFlags {
    /// The lobes of either BSDF (of a blend, or of the two sides of a surface).
    pub fn union(self, o: BsdfFlags) -> BsdfFlags {
        BsdfFlags {
            reflection: self.reflection || o.reflection,
            transmission: self.transmission || o.transmission,
            diffuse: self.diffuse || o.diffuse,
            glossy: self.glossy || o.glossy,
            specular: self.specular || o.specular,
        }
    }

    /// A microfacet lobe: specular where smooth, glossy where rough.
    fn microfacet(roughness: &Roughness, transmission: bool) -> BsdfFlags {
        let smooth = roughness.is_smooth();
        BsdfFlags {
            reflection: true,
            transmission,
            glossy: !smooth,
            specular: smooth,
            ..Default::default()
        }
    }
}

/// A constant or textured base colour ([`BsdfSpec::base_color`]).
#[derive(Clone, Copy, Debug)]
pub enum BaseColor<'a> {
    /// A reflectance texture (possibly constant).
    Texture(&'a Texture),
    /// A reflectance that is one colour everywhere.
    Rgb(Vec3),
}

impl BaseColor<'_> {
    /// The colour at texture coordinates `uv`.
    pub fn at(&self, uv: Vec2) -> Vec3 {
        match self {
            BaseColor::Texture(t) => t.eval(uv),
            BaseColor::Rgb(c) => *c,
        }
    }

    /// The colour where it is the same everywhere.
    pub fn constant(&self) -> Option<Vec3> {
        match self {
            BaseColor::Texture(Texture::Constant(c)) | BaseColor::Rgb(c) => Some(*c),
            BaseColor::Texture(_) => None,
        }
    }
}

impl Roughness {
    /// Whether the surface is perfectly smooth everywhere (α below [`SMOOTH_ALPHA`], no map).
    pub fn is_smooth(&self) -> bool {
        self.maps.is_none() && self.alpha_u.max(self.alpha_v) < SMOOTH_ALPHA
    }
}

impl BsdfSpec {
    /// The BSDF an adapter (mask, normal map, bump map) wraps; `None` for any other BSDF.
    #[inline]
    pub fn adapted(&self) -> Option<&BsdfSpec> {
        match self {
            BsdfSpec::NormalMap { nested, .. }
            | BsdfSpec::BumpMap { nested, .. }
            | BsdfSpec::Mask { nested, .. } => Some(nested),
            BsdfSpec::Diffuse { .. }
            | BsdfSpec::Mirror { .. }
            | BsdfSpec::Conductor { .. }
            | BsdfSpec::Plastic { .. }
            | BsdfSpec::Dielectric { .. }
            | BsdfSpec::ThinDielectric { .. }
            | BsdfSpec::GltfPbr { .. }
            | BsdfSpec::Principled(_)
            | BsdfSpec::TwoSided { .. }
            | BsdfSpec::Blend { .. } => None,
        }
    }

    /// The BSDF under every adapter (masks, normal and bump maps): the one that scatters.
    #[inline]
    pub fn innermost(&self) -> &BsdfSpec {
        let mut b = self;
        while let Some(nested) = b.adapted() {
            b = nested;
        }
        b
    }

    /// [`BsdfSpec::innermost`], to edit it in place.
    pub fn innermost_mut(&mut self) -> &mut BsdfSpec {
        // `adapted` again for the mutable borrow; the loop ends where `adapted` is `None`.
        let mut b = self;
        loop {
            match b {
                BsdfSpec::Mask { nested, .. }
                | BsdfSpec::NormalMap { nested, .. }
                | BsdfSpec::BumpMap { nested, .. } => b = nested,
                other => return other,
            }
        }
    }

    /// Which lobes the BSDF has; an adapter has its nested BSDF's (a mask also transmits
    /// straight through its holes), a two-branch material those of either branch.
    pub fn flags(&self) -> BsdfFlags {
        match self {
            BsdfSpec::Diffuse { .. } => BsdfFlags {
                reflection: true,
                diffuse: true,
                ..Default::default()
            },
            BsdfSpec::Mirror { .. } => BsdfFlags {
                reflection: true,
                specular: true,
                ..Default::default()
            },
            BsdfSpec::Conductor { roughness, .. } => BsdfFlags::microfacet(roughness, false),
            BsdfSpec::Plastic { roughness, .. } => BsdfFlags {
                diffuse: true,
                ..BsdfFlags::microfacet(roughness, false)
            },
            BsdfSpec::Dielectric { roughness, .. } => BsdfFlags::microfacet(roughness, true),
            BsdfSpec::ThinDielectric { .. } => BsdfFlags {
                reflection: true,
                transmission: true,
                specular: true,
                ..Default::default()
            },
            BsdfSpec::GltfPbr {
                metallic_roughness,
                metallic,
                roughness,
                extensions,
                ..
            } => {
                // A metallic-roughness texture varies both per texel: any lobe may be there.
                let textured = metallic_roughness.is_some();
                let smooth = roughness * roughness < SMOOTH_ALPHA;
                let ext = extensions.as_deref();
                // A clear coat adds a lobe of its own roughness.
                let coat = ext.filter(|e| e.clearcoat > 0.0);
                // A roughness texture may make a rough coat's texels smooth.
                let coat_smooth = coat.map(|e| e.clearcoat_roughness.powi(2) < SMOOTH_ALPHA);
                let coat_varies = coat.is_some_and(|e| e.clearcoat_roughness_texture.is_some());
                // A sheen is a broad lobe of its own.
                let sheen = ext.is_some_and(crate::GltfExtensions::has_sheen);
                BsdfFlags {
                    reflection: true,
                    diffuse: textured || *metallic < 1.0,
                    glossy: textured || !smooth || coat_smooth == Some(false) || sheen,
                    specular: textured || smooth || coat_smooth == Some(true) || coat_varies,
                    transmission: ext.is_some_and(crate::GltfExtensions::transmits),
                }
            }
            // Its main lobes are GGX of α ≥ 0.001: never a Dirac lobe.
            BsdfSpec::Principled(p) => BsdfFlags {
                reflection: true,
                transmission: p.transmits(),
                diffuse: p.has_diffuse(),
                glossy: true,
                specular: false,
            },
            BsdfSpec::NormalMap { nested, .. } | BsdfSpec::BumpMap { nested, .. } => nested.flags(),
            BsdfSpec::Mask { nested, .. } => nested.flags().union(BsdfFlags {
                transmission: true,
                specular: true,
                ..Default::default()
            }),
            BsdfSpec::TwoSided { front, back } => front.flags().union(back.flags()),
            BsdfSpec::Blend { first, second, .. } => first.flags().union(second.flags()),
        }
    }

    /// Whether the BSDF under the adapters lets light through to the other side (then the
    /// surface's two sides face different media, and its back is not black).
    pub fn transmits(&self) -> bool {
        self.innermost().flags().transmission
    }

    /// The microfacet roughness of the BSDF under the adapters; `None` for BSDFs without one
    /// (and for two-branch materials, whose branches have their own).
    pub fn roughness(&self) -> Option<&Roughness> {
        self.parameters().0
    }

    /// The colour that tints what the BSDF under the adapters reflects: a diffuse or plastic
    /// base's reflectance, a mirror's, a glTF material's base colour. `None` where the colour comes from elsewhere
    /// (a conductor's η and k, glass) or from two branches.
    pub fn base_color(&self) -> Option<BaseColor<'_>> {
        self.parameters().1
    }

    /// The roughness and base colour of the BSDF under the adapters, in one match.
    fn parameters(&self) -> (Option<&Roughness>, Option<BaseColor<'_>>) {
        match self.innermost() {
            BsdfSpec::Diffuse { reflectance } => (None, Some(BaseColor::Texture(reflectance))),
            BsdfSpec::Mirror { reflectance } => (None, Some(BaseColor::Rgb(*reflectance))),
            BsdfSpec::GltfPbr { base_color, .. } => (None, Some(BaseColor::Texture(base_color))),
            BsdfSpec::Principled(p) => (None, Some(BaseColor::Texture(&p.base_color))),
            BsdfSpec::Plastic {
                diffuse, roughness, ..
            } => (Some(roughness), Some(BaseColor::Texture(diffuse))),
            BsdfSpec::Conductor { roughness, .. } | BsdfSpec::Dielectric { roughness, .. } => {
                (Some(roughness), None)
            }
            BsdfSpec::ThinDielectric { .. }
            | BsdfSpec::TwoSided { .. }
            | BsdfSpec::Blend { .. }
            | BsdfSpec::NormalMap { .. }
            | BsdfSpec::BumpMap { .. }
            | BsdfSpec::Mask { .. } => (None, None),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn diffuse(c: f32) -> BsdfSpec {
        BsdfSpec::Diffuse {
            reflectance: Texture::Constant(Vec3::splat(c)),
        }
    }

    fn glass(alpha: f32) -> BsdfSpec {
        BsdfSpec::Dielectric {
            ior: 1.5,
            roughness: Roughness::ggx(alpha),
        }
    }

    /// `b` under a mask, a normal map and a bump map, outermost first.
    fn adapted(b: BsdfSpec) -> BsdfSpec {
        let t = Texture::Constant(Vec3::splat(0.5));
        BsdfSpec::Mask {
            opacity: t.clone(),
            cutoff: None,
            nested: Box::new(BsdfSpec::NormalMap {
                normals: t.clone(),
                nested: Box::new(BsdfSpec::BumpMap {
                    height: t,
                    scale: 1.0,
                    nested: Box::new(b),
                }),
            }),
        }
    }

    #[test]
    fn flags_name_each_bsdfs_lobes() {
        let f = diffuse(0.5).flags();
        assert!(f.reflection && f.diffuse && !f.transmission && !f.specular && !f.glossy);
        let f = glass(0.0).flags();
        assert!(f.reflection && f.transmission && f.specular && !f.glossy && !f.diffuse);
        let f = glass(0.3).flags();
        assert!(f.transmission && f.glossy && !f.specular);
        let f = BsdfSpec::ThinDielectric { ior: 1.5 }.flags();
        assert!(f.transmission && f.specular);
        let f = BsdfSpec::Plastic {
            diffuse: Texture::Constant(Vec3::ONE),
            ior: 1.5,
            roughness: Roughness::SMOOTH,
            nonlinear: false,
            exact_rough_coat: false,
        }
        .flags();
        assert!(f.reflection && f.diffuse && f.specular && !f.transmission);
        let f = BsdfSpec::Conductor {
            eta: Vec3::ONE,
            k: Vec3::ONE,
            roughness: Roughness::ggx(SMOOTH_ALPHA),
        }
        .flags();
        assert!(
            f.glossy && !f.specular && !f.diffuse,
            "α at the bound is rough"
        );
        let blend = BsdfSpec::Blend {
            weight: Texture::Constant(Vec3::splat(0.5)),
            first: Box::new(diffuse(0.5)),
            second: Box::new(glass(0.0)),
        };
        let f = blend.flags();
        assert!(f.diffuse && f.transmission && f.specular);
    }

    #[test]
    fn a_mask_transmits_but_the_bsdf_under_it_decides_which_side_is_black() {
        let masked = adapted(diffuse(0.5));
        assert!(
            masked.flags().transmission,
            "light passes through a mask's holes"
        );
        assert!(!masked.transmits(), "the diffuse under the mask is opaque");
        assert!(adapted(glass(0.0)).transmits());
        assert!(BsdfSpec::ThinDielectric { ior: 1.3 }.transmits());
    }

    #[test]
    fn innermost_sees_through_every_adapter() {
        let mut b = adapted(glass(0.2));
        assert!(matches!(b.innermost(), BsdfSpec::Dielectric { .. }));
        assert_eq!(b.roughness().map(|r| r.alpha_u), Some(0.2));
        if let BsdfSpec::Dielectric { ior, .. } = b.innermost_mut() {
            *ior = 1.33;
        }
        assert!(matches!(b.innermost(), BsdfSpec::Dielectric { ior, .. } if *ior == 1.33));
        let plain = diffuse(0.25);
        assert!(std::ptr::eq(plain.innermost(), &plain));
        assert!(plain.adapted().is_none() && plain.roughness().is_none());
    }

    #[test]
    fn base_colour_is_the_reflectance_under_the_adapters() {
        let b = adapted(diffuse(0.25));
        let c = b.base_color().expect("a diffuse has a base colour");
        assert_eq!(c.constant(), Some(Vec3::splat(0.25)));
        assert_eq!(c.at(Vec2::new(0.3, 0.7)), Vec3::splat(0.25));
        let mirror = BsdfSpec::Mirror {
            reflectance: Vec3::new(0.9, 0.8, 0.7),
        };
        assert_eq!(
            mirror.base_color().and_then(|c| c.constant()),
            Some(Vec3::new(0.9, 0.8, 0.7))
        );
        assert!(glass(0.0).base_color().is_none());
    }
}
