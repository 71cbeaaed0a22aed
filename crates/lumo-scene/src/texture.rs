use std::sync::Arc;

use glam::{Affine2, Vec2, Vec3};
use lumo_image::Image;

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
    /// A linear-RGB bitmap, repeated, nearest-neighbour lookup (v = 0 at the bottom row).
    Bitmap {
        /// The pixels.
        image: Arc<Image>,
        /// uv multiplier (tiling).
        uv_scale: Vec2,
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
    /// The value at `uv`.
    pub fn eval(&self, uv: Vec2) -> Vec3 {
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
            Texture::Bitmap { image, uv_scale } => {
                let uv = uv * *uv_scale;
                let (w, h) = (image.width, image.height);
                let x = ((uv.x - uv.x.floor()) * w as f32) as usize;
                let y = ((1.0 - (uv.y - uv.y.floor())) * h as f32) as usize;
                let rgb = image.rgb(x.min(w - 1), y.min(h - 1));
                Vec3::from(rgb)
            }
            Texture::Transformed { texture, uv: m } => texture.eval(m.transform_point2(uv)),
        }
    }

    /// Mean value (exact for constant and checkerboard, pixel mean for bitmaps).
    pub fn average(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard { color0, color1, .. } => (*color0 + *color1) * 0.5,
            Texture::Bitmap { image, .. } => {
                let m = image.to_channels(3).channel_means();
                Vec3::new(m[0] as f32, m[1] as f32, m[2] as f32)
            }
            // Exact for affine maps that tile whole periods; close otherwise.
            Texture::Transformed { texture, .. } => texture.average(),
        }
    }
}
