//! The AOV planes a render produces, and writing them as the file set `lumo denoise` reads.

use std::path::Path;

use lumo_image::{write_image, Image, ImageError};

/// File names of the AOV planes, in the order [`Frame::planes`] returns them.
pub const AOV_NAMES: [&str; 9] = [
    "color", "albedo", "normal", "position", "depth", "direct", "indirect", "variance", "emission",
];

/// A rendered image with its auxiliary planes.
#[derive(Clone, Debug)]
pub struct Frame {
    /// Samples per pixel.
    pub spp: u32,
    /// Mean radiance (= direct + indirect), RGB.
    pub color: Image,
    /// Emission seen directly plus direct illumination, RGB.
    pub direct: Image,
    /// Indirect illumination, RGB.
    pub indirect: Image,
    /// First-hit reflectance of the pixel-centre ray, RGB (0 where nothing was hit).
    pub albedo: Image,
    /// First-hit shading normal facing the camera, world space in [-1,1] (0 on a miss).
    pub normal: Image,
    /// First-hit world position (0 on a miss).
    pub position: Image,
    /// First-hit distance from the camera, one channel (+Inf on a miss).
    pub depth: Image,
    /// Variance of the pixel mean's luminance, one channel. With one sample per pixel the
    /// renderer leaves 0 (a sample's variance cannot be known alone); lumo-pipeline's frames
    /// estimate it from the 3×3 neighbourhood instead.
    pub variance: Image,
    /// Radiance emitted towards the camera by what the pixel-centre ray hits first (a light, or
    /// the environment where the ray escapes), RGB: the noise-free part of the image that a
    /// filter must leave alone (like Blender's Emit pass; `lumo denoise` reads it).
    pub emission: Image,
    /// The mean over each pixel's samples of what `emission` records for one: on a light's
    /// anti-aliased rim, the light's share of the pixel, which filters keep out
    /// (`lumo_filter::with_emitted`). Not an AOV file (`emission` is the one written).
    pub emitted: Image,
}

impl Frame {
    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.color.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.color.height
    }

    /// All planes with their file names.
    pub fn planes(&self) -> [(&'static str, &Image); 9] {
        let images = [
            &self.color,
            &self.albedo,
            &self.normal,
            &self.position,
            &self.depth,
            &self.direct,
            &self.indirect,
            &self.variance,
            &self.emission,
        ];
        std::array::from_fn(|i| (AOV_NAMES[i], images[i]))
    }

    /// Writes every plane as `DIR/<name>.exr` (float32), creating DIR if needed.
    pub fn write_aovs(&self, dir: &Path) -> Result<(), ImageError> {
        std::fs::create_dir_all(dir).map_err(|source| ImageError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        for (name, image) in self.planes() {
            write_image(&dir.join(format!("{name}.exr")), image)?;
        }
        Ok(())
    }
}
