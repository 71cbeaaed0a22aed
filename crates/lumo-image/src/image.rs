use crate::ImageError;

/// A float image: `channels` interleaved values per pixel, rows top to bottom.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Values per pixel (1 for depth or variance, 3 for RGB, normals, positions).
    pub channels: usize,
    /// `width * height * channels` values, pixel-major.
    pub data: Vec<f32>,
}

impl Image {
    /// An image filled with `value`.
    pub fn new(width: usize, height: usize, channels: usize, value: f32) -> Self {
        Self {
            width,
            height,
            channels,
            data: vec![value; width * height * channels],
        }
    }

    /// Wraps existing data; panics if the length does not match (a programming error).
    pub fn from_vec(width: usize, height: usize, channels: usize, data: Vec<f32>) -> Self {
        assert_eq!(data.len(), width * height * channels, "image data length");
        Self {
            width,
            height,
            channels,
            data,
        }
    }

    /// Number of pixels.
    pub fn pixel_count(&self) -> usize {
        self.width * self.height
    }

    /// The values of pixel (x, y).
    #[inline]
    pub fn pixel(&self, x: usize, y: usize) -> &[f32] {
        let i = (y * self.width + x) * self.channels;
        &self.data[i..i + self.channels]
    }

    /// Mutable values of pixel (x, y).
    #[inline]
    pub fn pixel_mut(&mut self, x: usize, y: usize) -> &mut [f32] {
        let i = (y * self.width + x) * self.channels;
        &mut self.data[i..i + self.channels]
    }

    /// The RGB triple of pixel (x, y); a one-channel image is broadcast to grey.
    #[inline]
    pub fn rgb(&self, x: usize, y: usize) -> [f32; 3] {
        rgb_of(self.pixel(x, y))
    }

    /// This image with exactly `channels` channels: grey is broadcast, extra channels dropped.
    pub fn to_channels(&self, channels: usize) -> Image {
        if channels == self.channels {
            return self.clone();
        }
        let mut out = Image::new(self.width, self.height, channels, 0.0);
        for (src, dst) in self
            .data
            .chunks_exact(self.channels)
            .zip(out.data.chunks_exact_mut(channels))
        {
            for (c, d) in dst.iter_mut().enumerate() {
                *d = if self.channels == 1 {
                    src[0]
                } else {
                    src.get(c).copied().unwrap_or(0.0)
                };
            }
        }
        out
    }

    /// Mean of each channel over the whole image (f64 accumulation).
    pub fn channel_means(&self) -> Vec<f64> {
        let mut sums = vec![0.0f64; self.channels];
        for px in self.data.chunks_exact(self.channels) {
            for (s, v) in sums.iter_mut().zip(px) {
                *s += *v as f64;
            }
        }
        let n = self.pixel_count().max(1) as f64;
        sums.iter().map(|s| s / n).collect()
    }

    /// Adds `scale ·` the first channels of `plane` (same size; at least as many channels as
    /// used) to this image where this image's value and the plane's are finite: a missing
    /// (non-finite) pixel stays missing. Used to take an exactly known light out of a filter's
    /// input and to put it back after.
    pub fn add_scaled_finite(&mut self, plane: &Image, scale: f32) {
        let (c, pc) = (self.channels, plane.channels);
        for (p, q) in self
            .data
            .chunks_exact_mut(c)
            .zip(plane.data.chunks_exact(pc))
        {
            for (v, d) in p.iter_mut().zip(q) {
                if v.is_finite() && d.is_finite() {
                    *v += scale * d;
                }
            }
        }
    }

    /// Count of values that are NaN or infinite.
    pub fn non_finite_count(&self) -> usize {
        self.data.iter().filter(|v| !v.is_finite()).count()
    }

    /// Error unless `other` has the same width and height; `a`/`b` name the two in the message.
    pub fn check_same_size(&self, a: &str, other: &Image, b: &str) -> Result<(), ImageError> {
        if self.width == other.width && self.height == other.height {
            Ok(())
        } else {
            Err(ImageError::SizeMismatch {
                a: a.to_string(),
                aw: self.width,
                ah: self.height,
                b: b.to_string(),
                bw: other.width,
                bh: other.height,
            })
        }
    }
}

/// The RGB triple of one pixel's channels (`pixel.len()` of them): one channel is broadcast to
/// grey, a missing blue is 0, channels after the third are ignored.
#[inline]
pub fn rgb_of(pixel: &[f32]) -> [f32; 3] {
    match pixel.len() {
        1 => [pixel[0]; 3],
        2 => [pixel[0], pixel[1], 0.0],
        _ => [pixel[0], pixel[1], pixel[2]],
    }
}
