use std::sync::Arc;

use glam::{Affine2, Vec2, Vec3};
use lumo_image::Image;

use crate::mipmap::{MipFilter, MipMap};

/// How a bitmap lookup between texel centres is reconstructed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TextureFilter {
    /// The texel that contains the point.
    #[default]
    Nearest,
    /// Bilinear interpolation of the four nearest texel centres (Mitsuba's default).
    Bilinear,
}

/// What a bitmap holds outside [0, 1]² (applied to each texel index, as Mitsuba does).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    /// Tiled.
    #[default]
    Repeat,
    /// Tiled, every other copy mirrored.
    Mirror,
    /// The edge texels extended.
    Clamp,
}

impl WrapMode {
    /// The texel index in `0..n` (n ≥ 1) that stands for index `i`.
    #[inline]
    pub fn index(self, i: i64, n: usize) -> usize {
        let n = n.max(1) as i64;
        let j = match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let p = i.rem_euclid(2 * n);
                if p >= n {
                    2 * n - 1 - p
                } else {
                    p
                }
            }
        };
        j as usize
    }
}

/// Where a bitmap lookup at some uv falls: texel coordinates (texel (i, j) covers
/// [i, i+1) × [j, j+1), row 0 at v = 1) with the image's size and wrap mode. Shared by the
/// lookup and its gradient so the two cannot disagree.
struct TexelGrid {
    px: f32,
    py: f32,
    w: usize,
    h: usize,
    wrap: WrapMode,
}

impl TexelGrid {
    /// `None` for an empty image.
    fn new(image: &Image, wrap: WrapMode, uv: Vec2) -> Option<Self> {
        let (w, h) = (image.width, image.height);
        (w > 0 && h > 0).then_some(Self {
            px: uv.x * w as f32,
            py: (1.0 - uv.y) * h as f32,
            w,
            h,
            wrap,
        })
    }

    /// The texel containing the point.
    fn nearest(&self) -> (usize, usize) {
        (
            self.wrap.index(self.px.floor() as i64, self.w),
            self.wrap.index(self.py.floor() as i64, self.h),
        )
    }

    /// The four nearest texel centres as columns [x0, x1] and rows [y0, y1], and the weights
    /// of x1 and y1 (as Mitsuba's bitmap).
    fn bilinear(&self) -> ([usize; 2], [usize; 2], f32, f32) {
        let (fx, fy) = (self.px - 0.5, self.py - 0.5);
        let (x0, y0) = (fx.floor(), fy.floor());
        let (xi, yi) = (x0 as i64, y0 as i64);
        (
            [self.wrap.index(xi, self.w), self.wrap.index(xi + 1, self.w)],
            [self.wrap.index(yi, self.h), self.wrap.index(yi + 1, self.h)],
            fx - x0,
            fy - y0,
        )
    }
}

/// A spatially varying reflectance, looked up by texture coordinates.
#[derive(Clone, Debug)]
pub enum Texture {
    /// The same value everywhere.
    Constant(Vec3),
    /// Alternating squares: `color0` where `floor(u*scale) + floor(v*scale)` is even.
    Checkerboard {
        /// Colour of the even squares.
        color0: Vec3,
        /// Colour of the odd squares.
        color1: Vec3,
        /// Squares per unit of uv.
        scale: f32,
    },
    /// A linear-RGB bitmap (v = 0 at the bottom row).
    Bitmap {
        /// The pixels.
        image: Arc<Image>,
        /// uv multiplier (tiling).
        uv_scale: Vec2,
        /// How a lookup between texel centres is reconstructed.
        filter: TextureFilter,
        /// What lies outside [0, 1]².
        wrap: WrapMode,
    },
    /// A bitmap with its mip-map (glTF's `*_MIPMAP_*` minification filters): looked up in
    /// the level whose texels match the lookup's footprint ([`Texture::eval_at`]); a lookup
    /// without a footprint reads level 0 as a [`Texture::Bitmap`] would.
    Mipmapped {
        /// The levels.
        mips: Arc<MipMap>,
        /// The lookup within level 0 where the footprint is under a texel (glTF's
        /// `magFilter`).
        magnify: TextureFilter,
        /// The lookup within a reduced level (the first half of glTF's `minFilter` name).
        minify: TextureFilter,
        /// How two levels are combined.
        between: MipFilter,
        /// What lies outside [0, 1]².
        wrap: WrapMode,
    },
    /// Another texture looked up at transformed coordinates (Mitsuba's `to_uv`, glTF's
    /// `KHR_texture_transform`).
    Transformed {
        /// The texture.
        texture: Arc<Texture>,
        /// uv → the texture's uv.
        uv: Affine2,
    },
}

impl Texture {
    /// The value at `uv` (a point lookup: a mip-map reads its finest level).
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        self.eval_at(uv, 0.0)
    }

    /// The value at `uv` averaged over a footprint about `footprint` wide in uv units (only
    /// a [`Texture::Mipmapped`] reads the footprint; zero is a point lookup).
    pub fn eval_at(&self, uv: Vec2, footprint: f32) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard {
                color0,
                color1,
                scale,
            } => {
                let s = (uv.x * scale).floor() as i64 + (uv.y * scale).floor() as i64;
                if s.rem_euclid(2) == 0 {
                    *color0
                } else {
                    *color1
                }
            }
            Texture::Bitmap {
                image,
                uv_scale,
                filter,
                wrap,
            } => lookup(image, *filter, *wrap, uv * *uv_scale),
            Texture::Mipmapped {
                mips,
                magnify,
                minify,
                between,
                wrap,
            } => {
                let levels = mips.levels();
                let level = mips.level_for(footprint);
                if level <= 0.0 {
                    return lookup(&levels[0], *magnify, *wrap, uv);
                }
                let at = |i: usize| lookup(&levels[i], *minify, *wrap, uv);
                let (lo, t) = (level.floor(), level.fract());
                match between {
                    MipFilter::Nearest => at(level.round() as usize),
                    MipFilter::Linear if t == 0.0 => at(lo as usize),
                    MipFilter::Linear => at(lo as usize) * (1.0 - t) + at(lo as usize + 1) * t,
                }
            }
            Texture::Transformed { texture, uv: m } => {
                // The footprint scales as lengths do under the map (its area's square root).
                let scale = m.matrix2.determinant().abs().sqrt();
                texture.eval_at(m.transform_point2(uv), footprint * scale)
            }
        }
    }

    /// Whether a lookup reads its footprint (a mip-map somewhere inside).
    pub fn uses_footprint(&self) -> bool {
        match self {
            Texture::Mipmapped { .. } => true,
            Texture::Transformed { texture, .. } => texture.uses_footprint(),
            _ => false,
        }
    }

    /// The scalar value at `uv`: the luminance of the colour (a grey texture's own value), as
    /// Mitsuba reads a colour texture where a number is expected.
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        lumo_image::luminance(self.eval(uv).to_array())
    }

    /// [`Texture::eval_1`] over a footprint ([`Texture::eval_at`]).
    pub fn eval_1_at(&self, uv: Vec2, footprint: f32) -> f32 {
        lumo_image::luminance(self.eval_at(uv, footprint).to_array())
    }

    /// Gradient (∂/∂u, ∂/∂v) of [`Texture::eval_1`] at `uv`, as Mitsuba's `eval_1_grad`: exact
    /// for bilinear bitmaps, zero where the texture is piecewise constant (constant,
    /// checkerboard, nearest-filtered bitmaps). A mip-map's is its finest level's.
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Constant(_) | Texture::Checkerboard { .. } => Vec2::ZERO,
            Texture::Bitmap {
                image,
                uv_scale,
                filter,
                wrap,
            } => lookup_grad(image, *filter, *wrap, uv * *uv_scale) * *uv_scale,
            Texture::Mipmapped {
                mips,
                magnify,
                wrap,
                ..
            } => lookup_grad(&mips.levels()[0], *magnify, *wrap, uv),
            Texture::Transformed { texture, uv: m } => {
                // Chain rule: the gradient pulled back through the affine map (its transpose).
                let g = texture.eval_1_grad(m.transform_point2(uv));
                m.matrix2.transpose() * g
            }
        }
    }

    /// Mean value (exact for constant and checkerboard, pixel mean for bitmaps).
    pub fn average(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard { color0, color1, .. } => (*color0 + *color1) * 0.5,
            Texture::Bitmap { image, .. } => colour_mean(image),
            Texture::Mipmapped { mips, .. } => colour_mean(&mips.levels()[0]),
            // Exact for affine maps that tile whole periods; close otherwise.
            Texture::Transformed { texture, .. } => texture.average(),
        }
    }
}

/// The mean colour of `image`'s pixels.
fn colour_mean(image: &Image) -> Vec3 {
    let m = image.to_channels(3).channel_means();
    Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
}

/// A bitmap read at `uv` (the image spanning [0, 1]²) with `filter` and `wrap`.
#[inline]
fn lookup(image: &Image, filter: TextureFilter, wrap: WrapMode, uv: Vec2) -> Vec3 {
    // The loaders refuse empty images; one built in code must not panic here.
    let Some(grid) = TexelGrid::new(image, wrap, uv) else {
        return Vec3::ZERO;
    };
    let texel = |x: usize, y: usize| Vec3::from(image.rgb(x, y));
    match filter {
        TextureFilter::Nearest => {
            let (x, y) = grid.nearest();
            texel(x, y)
        }
        TextureFilter::Bilinear => {
            let ([x0, x1], [y0, y1], tx, ty) = grid.bilinear();
            let top = texel(x0, y0) * (1.0 - tx) + texel(x1, y0) * tx;
            let bottom = texel(x0, y1) * (1.0 - tx) + texel(x1, y1) * tx;
            top * (1.0 - ty) + bottom * ty
        }
    }
}

/// The gradient of [`lookup`]'s luminance with respect to the uv it was given: exact for
/// bilinear lookups, zero for nearest ones (piecewise constant).
fn lookup_grad(image: &Image, filter: TextureFilter, wrap: WrapMode, uv: Vec2) -> Vec2 {
    if filter == TextureFilter::Nearest {
        return Vec2::ZERO;
    }
    let Some(grid) = TexelGrid::new(image, wrap, uv) else {
        return Vec2::ZERO;
    };
    let ([x0, x1], [y0, y1], tx, ty) = grid.bilinear();
    let texel = |x: usize, y: usize| lumo_image::luminance(image.rgb(x, y));
    let (f00, f10) = (texel(x0, y0), texel(x1, y0));
    let (f01, f11) = (texel(x0, y1), texel(x1, y1));
    let d_px = (1.0 - ty) * (f10 - f00) + ty * (f11 - f01);
    let d_py = (1.0 - tx) * (f01 - f00) + tx * (f11 - f10);
    // px grows with u; py falls as v grows (row 0 at v = 1).
    let (w, h) = (image.width as f32, image.height as f32);
    Vec2::new(d_px * w, -d_py * h)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp() -> Texture {
        // 4×1 texels with values 0, 1, 2, 3.
        let data = (0..4).flat_map(|i| [i as f32; 3]).collect();
        Texture::Bitmap {
            image: Arc::new(Image::from_vec(4, 1, 3, data)),
            uv_scale: Vec2::ONE,
            filter: TextureFilter::Bilinear,
            wrap: WrapMode::Clamp,
        }
    }

    #[test]
    fn bilinear_interpolates_between_texel_centres() {
        let t = ramp();
        // Texel centres at u = (i + 0.5) / 4 give the texel values exactly.
        for i in 0..4 {
            let u = (i as f32 + 0.5) / 4.0;
            assert!((t.eval(Vec2::new(u, 0.5)).x - i as f32).abs() < 1e-5);
        }
        // Halfway between centres 1 and 2.
        assert!((t.eval(Vec2::new(0.5, 0.5)).x - 1.5).abs() < 1e-5);
        // Clamped beyond the edges.
        assert_eq!(t.eval(Vec2::new(-3.0, 0.5)).x, 0.0);
        assert_eq!(t.eval(Vec2::new(7.0, 0.5)).x, 3.0);
    }

    #[test]
    fn gradient_matches_finite_differences() {
        // A 3×3 bitmap, varying along both axes, under a rotation and scale of uv.
        let data = (0..9)
            .flat_map(|i| [((i % 3) * (i / 3 + 1)) as f32 + 0.3 * (i / 3) as f32; 3])
            .collect();
        let bitmap = Texture::Bitmap {
            image: Arc::new(Image::from_vec(3, 3, 3, data)),
            uv_scale: Vec2::new(1.0, 2.0),
            filter: TextureFilter::Bilinear,
            wrap: WrapMode::Repeat,
        };
        let t = Texture::Transformed {
            texture: Arc::new(bitmap),
            uv: Affine2::from_angle(0.4) * Affine2::from_scale(Vec2::new(1.5, 0.7)),
        };
        for uv in [
            Vec2::new(0.31, 0.17),
            Vec2::new(0.62, 0.05),
            Vec2::new(0.1, 0.4),
        ] {
            let h = 1e-3;
            let du = (t.eval_1(uv + Vec2::X * h) - t.eval_1(uv - Vec2::X * h)) / (2.0 * h);
            let dv = (t.eval_1(uv + Vec2::Y * h) - t.eval_1(uv - Vec2::Y * h)) / (2.0 * h);
            let g = t.eval_1_grad(uv);
            assert!(
                (g - Vec2::new(du, dv)).length() < 0.02 * (1.0 + g.length()),
                "{g} vs {du} {dv}"
            );
        }
        assert_eq!(
            Texture::Constant(Vec3::ONE).eval_1_grad(Vec2::ZERO),
            Vec2::ZERO
        );
    }

    #[test]
    fn wrap_modes_map_indices_as_mitsuba_does() {
        let idx = |m: WrapMode| (-5..9).map(|i| m.index(i, 4)).collect::<Vec<_>>();
        assert_eq!(
            idx(WrapMode::Repeat),
            [3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0]
        );
        assert_eq!(
            idx(WrapMode::Clamp),
            [0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3]
        );
        assert_eq!(
            idx(WrapMode::Mirror),
            [3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0]
        );
    }

    #[test]
    fn nearest_takes_the_containing_texel() {
        let Texture::Bitmap { image, .. } = ramp() else {
            unreachable!()
        };
        let t = Texture::Bitmap {
            image,
            uv_scale: Vec2::ONE,
            filter: TextureFilter::Nearest,
            wrap: WrapMode::Repeat,
        };
        assert_eq!(t.eval(Vec2::new(0.30, 0.5)).x, 1.0);
        assert_eq!(t.eval(Vec2::new(1.30, 0.5)).x, 1.0);
        assert_eq!(t.eval(Vec2::new(-0.05, 0.5)).x, 3.0);
    }

    /// An 8×8 bitmap of one-texel black and white squares, mip-mapped.
    fn mip_checker(between: MipFilter) -> Texture {
        let data = (0..64)
            .flat_map(|i| [((i % 8 + i / 8) % 2) as f32; 3])
            .collect();
        Texture::Mipmapped {
            mips: Arc::new(MipMap::new(Arc::new(Image::from_vec(8, 8, 3, data)))),
            magnify: TextureFilter::Nearest,
            minify: TextureFilter::Bilinear,
            between,
            wrap: WrapMode::Repeat,
        }
    }

    #[test]
    fn a_point_lookup_of_a_mip_map_reads_its_finest_level() {
        let t = mip_checker(MipFilter::Linear);
        let Texture::Mipmapped { mips, .. } = &t else {
            unreachable!()
        };
        let plain = Texture::Bitmap {
            image: mips.levels()[0].clone(),
            uv_scale: Vec2::ONE,
            filter: TextureFilter::Nearest,
            wrap: WrapMode::Repeat,
        };
        for uv in [
            Vec2::new(0.01, 0.3),
            Vec2::new(0.55, 0.93),
            Vec2::new(-0.2, 1.7),
        ] {
            assert_eq!(t.eval(uv), plain.eval(uv));
            // A footprint under one texel is still a point lookup.
            assert_eq!(t.eval_at(uv, 0.1 / 8.0), plain.eval(uv));
        }
    }

    #[test]
    fn a_wide_footprint_reads_the_mean_and_levels_blend_linearly() {
        let t = mip_checker(MipFilter::Linear);
        // Two texels wide: level 1, where every 2×2 block of the checker is grey.
        let uv = Vec2::new(0.3, 0.6);
        assert!((t.eval_at(uv, 2.0 / 8.0).x - 0.5).abs() < 1e-6);
        // Wider than the image: the single texel of the last level, the mean.
        assert!((t.eval_at(uv, 4.0).x - 0.5).abs() < 1e-6);
        // Between level 0 and level 1 the two lookups are weighted by the fractional level.
        let Texture::Mipmapped { mips, .. } = &t else {
            unreachable!()
        };
        let l0 = lookup(
            &mips.levels()[0],
            TextureFilter::Bilinear,
            WrapMode::Repeat,
            uv,
        )
        .x;
        let footprint = 2f32.powf(0.25) / 8.0;
        let v = t.eval_at(uv, footprint).x;
        assert!((v - (0.75 * l0 + 0.25 * 0.5)).abs() < 1e-5, "{v} {l0}");
        // Nearest between levels takes level 0 here (0.25 rounds down).
        let n = mip_checker(MipFilter::Nearest).eval_at(uv, footprint).x;
        assert!((n - l0).abs() < 1e-6);
    }

    #[test]
    fn a_transform_scales_the_footprint_with_the_uv() {
        // uv scaled by 4: the texture repeats 4× as often, so a footprint of a quarter
        // texel before the map covers a whole one after it, and one of half a texel two.
        let t = Texture::Transformed {
            texture: Arc::new(mip_checker(MipFilter::Linear)),
            uv: Affine2::from_scale(Vec2::splat(4.0)),
        };
        let uv = Vec2::new(0.07, 0.11);
        assert_eq!(t.eval_at(uv, 0.25 / 8.0), t.eval(uv));
        assert!((t.eval_at(uv, 0.5 / 8.0).x - 0.5).abs() < 1e-6);
        assert!(t.uses_footprint() && !ramp().uses_footprint());
    }
}
