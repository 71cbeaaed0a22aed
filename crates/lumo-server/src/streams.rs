//! The two sample streams of the progressive client/server paper: camera samples from the
//! path tracer and light splats from the light tracer, both as `([u,v], [X,Y,Z,W])` in CIE XYZ.
//!
//! Camera samples visit the screen in a low-discrepancy order that never forms tiles: sample
//! `n` belongs to pass `n / 4^L` and, within the pass, to the pixel whose Morton index is the
//! bit reversal of `n mod 4^L` (2^L ≥ the image's larger side). Every prefix of `4^k` samples of
//! a pass is a regular lattice with spacing `2^(L-k)` pixels, so a few samples already cover
//! the whole image evenly. Within a pixel, pass `p` uses sample `p` of that pixel's Owen-scrambled
//! Sobol sequence, so a pixel's samples are stratified exactly as in `lumo render`. What a
//! sample is comes from the integrator's own entry in lumo-render's table
//! ([`Integrator::stream_camera_sample`], [`Integrator::stream_light_path`]); this file only
//! orders, scales and converts.

use glam::{Vec2, Vec3};
use lumo_render::stream::{SampleStream, StreamSample, StreamValue};
use lumo_render::Integrator;

/// One sample of either stream.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Screen position in [0,1]² (u right, v down).
    pub uv: [f32; 2],
    /// CIE XYZ colour and weight.
    pub xyzw: [f32; 4],
}

/// Linear sRGB (Rec. 709 primaries, D65) to CIE XYZ.
#[inline]
pub fn rgb_to_xyz(c: Vec3) -> [f32; 3] {
    [
        0.412_456_4 * c.x + 0.357_576_1 * c.y + 0.180_437_5 * c.z,
        0.212_672_9 * c.x + 0.715_152_2 * c.y + 0.072_175 * c.z,
        0.019_333_9 * c.x + 0.119_192 * c.y + 0.950_304_1 * c.z,
    ]
}

/// The order in which camera samples visit pixels.
#[derive(Clone, Copy, Debug)]
pub struct ScreenOrder {
    width: u32,
    height: u32,
    /// L: the padded square is 2^L × 2^L.
    bits: u32,
}

/// Gathers the even bits of `v` (a Morton index) into one coordinate.
fn compact(mut v: u64) -> u64 {
    v &= 0x5555_5555;
    v = (v | (v >> 1)) & 0x3333_3333;
    v = (v | (v >> 2)) & 0x0f0f_0f0f;
    v = (v | (v >> 4)) & 0x00ff_00ff;
    (v | (v >> 8)) & 0xffff
}

impl ScreenOrder {
    /// The order for a `width`×`height` image (each side at most 65536).
    pub fn new(width: u32, height: u32) -> Self {
        let side = width.max(height).max(1);
        Self {
            width,
            height,
            bits: side.next_power_of_two().trailing_zeros(),
        }
    }

    /// Sample indices per pass (some fall outside a non-square image and are skipped).
    pub fn period(&self) -> u64 {
        1u64 << (2 * self.bits)
    }

    /// Pixel visited at position `k` of a pass (`k < period`), if inside the image.
    pub fn pixel(&self, k: u64) -> Option<(u32, u32)> {
        let n = 2 * self.bits;
        let morton = if n == 0 {
            0
        } else {
            k.reverse_bits() >> (64 - n)
        };
        // Even bits carry y so that the very first steps alternate rows and columns.
        let (x, y) = (compact(morton >> 1) as u32, compact(morton) as u32);
        (x < self.width && y < self.height).then_some((x, y))
    }
}

/// Everything a stream needs to turn sample indices into samples.
pub struct StreamContext<'a> {
    /// The integrators' samples by pixel, pass and light path number.
    pub stream: SampleStream<'a>,
    /// Pixel order.
    pub order: ScreenOrder,
    /// Image size.
    pub size: Vec2,
    /// Factor on every value (½ when two integrators estimate the same image).
    pub scale: f32,
}

impl StreamContext<'_> {
    /// The pass camera sample `n` belongs to: a pixel's `pass`-th sample.
    pub fn pass(&self, n: u64) -> u32 {
        (n / self.order.period()).min(u32::MAX as u64) as u32
    }

    /// A sample of the integrators as a stream sample (scaled, in CIE XYZ, at its place on
    /// the screen).
    fn sample(&self, s: StreamSample) -> Sample {
        let [x, y, z] = match s.value {
            StreamValue::Rgb(c) => rgb_to_xyz(c * self.scale),
            // A spectral path's XYZ straight from its wavelengths, not through RGB.
            StreamValue::Xyz(xyz) => (xyz * self.scale).to_array(),
        };
        let uv = s.film / self.size;
        Sample {
            uv: [uv.x, uv.y],
            xyzw: [x, y, z, 1.0],
        }
    }

    /// `integrator`'s camera sample `n` and its rays, or None when its index falls outside a
    /// non-square image (or the integrator has no camera samples). Samples it also feeds the
    /// light stream with are pushed to `light`.
    pub fn camera_sample(
        &self,
        integrator: Integrator,
        n: u64,
        light: &mut Vec<Sample>,
    ) -> Option<(Sample, u32)> {
        let (x, y) = self.order.pixel(n % self.order.period())?;
        let (s, rays) =
            integrator.stream_camera_sample(&self.stream, x, y, self.pass(n), &mut |s| {
                light.push(self.sample(s))
            })?;
        Some((self.sample(s), rays))
    }

    /// `integrator`'s light path `m`: pushes its splats (W = 1: each counts once in the splat
    /// density) and returns its rays (None for an integrator without light paths).
    pub fn light_path(&self, integrator: Integrator, m: u64, out: &mut Vec<Sample>) -> Option<u32> {
        integrator.stream_light_path(&self.stream, m, &mut |s| out.push(self.sample(s)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pass_visits_every_pixel_once_and_prefixes_are_even() {
        let order = ScreenOrder::new(24, 10);
        let mut seen = vec![0u32; 24 * 10];
        for k in 0..order.period() {
            if let Some((x, y)) = order.pixel(k) {
                seen[(y * 24 + x) as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&c| c == 1));
        // The first 16 indices of a 32×32 square form a 4×4 lattice, 8 pixels apart: no tiles.
        let sq = ScreenOrder::new(32, 32);
        let mut pts: Vec<(u32, u32)> = (0..16).filter_map(|k| sq.pixel(k)).collect();
        pts.sort();
        let lattice: Vec<(u32, u32)> = (0..4)
            .flat_map(|x| (0..4).map(move |y| (x * 8, y * 8)))
            .collect();
        assert_eq!(pts, lattice);
    }

    use lumo_render::camera::PinholeCamera;
    use lumo_render::stream::StreamRun;
    use lumo_render::{PathSettings, RenderScene};

    /// The streams of a `w`×`h` image of `rs` at full weight.
    fn test_context<'a>(
        rs: &'a RenderScene,
        run: &'a StreamRun,
        (w, h): (usize, usize),
        path: PathSettings,
        seed: u32,
    ) -> StreamContext<'a> {
        let order = ScreenOrder::new(w as u32, h as u32);
        let camera = PinholeCamera::new(&rs.scene.camera, w, h);
        let pixels = (w * h) as u64;
        StreamContext {
            stream: SampleStream::new(rs, camera, path, seed, run, pixels, order.period(), 256),
            order,
            size: Vec2::new(w as f32, h as f32),
            scale: 1.0,
        }
    }

    /// The viewer's reconstruction of the bidirectional streams (camera samples averaged per
    /// pixel, light splats summed and divided by the number of samples) estimates the same
    /// image as the path tracer.
    #[test]
    fn bidirectional_streams_add_up_to_the_path_tracers_image() {
        use lumo_render::{render, RenderSettings};
        let rs = RenderScene::new(lumo_scene::builtin_scene("cornell").expect("builtin"))
            .expect("scene");
        let (w, h) = (16usize, 16usize);
        let path = PathSettings {
            max_depth: 5,
            ..Default::default()
        };
        let run = StreamRun::new(&[Integrator::Bdpt], &rs, Default::default());
        let ctx = test_context(&rs, &run, (w, h), path, 2);
        let (mut camera, mut counts) = (vec![0.0f64; w * h], vec![0u32; w * h]);
        let mut light = Vec::new();
        let mut paths = 0u64;
        for n in 0..ctx.order.period() * 256 {
            if let Some((s, _)) = ctx.camera_sample(Integrator::Bdpt, n, &mut light) {
                let (x, y) = ((s.uv[0] * w as f32) as usize, (s.uv[1] * h as f32) as usize);
                camera[y * w + x] += s.xyzw[1] as f64;
                counts[y * w + x] += 1;
                paths += 1;
            }
        }
        let splats: f64 = light.iter().map(|s| s.xyzw[1] as f64).sum();
        let streamed = camera
            .iter()
            .zip(&counts)
            .map(|(c, &k)| c / k.max(1) as f64)
            .sum::<f64>()
            / (w * h) as f64
            + splats / paths as f64 / (w * h) as f64;
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 256,
            seed: 2,
            path,
        };
        let frame = render(&rs, &settings, &|_| {}).0;
        let reference = (0..w * h)
            .map(|i| rgb_to_xyz(Vec3::from(frame.color.rgb(i % w, i / w)))[1] as f64)
            .sum::<f64>()
            / (w * h) as f64;
        assert!(
            !light.is_empty() && (streamed / reference - 1.0).abs() < 0.02,
            "streams {streamed}, path tracer {reference}"
        );
    }

    /// Under spectral transport the camera stream's XYZ samples estimate the spectral path
    /// tracer's image, per XYZ channel.
    #[test]
    fn spectral_camera_samples_estimate_the_spectral_image() {
        use lumo_render::{render, RenderSettings};
        let rs = RenderScene::new(lumo_scene::builtin_scene("cornell").expect("builtin"))
            .expect("scene");
        let (w, h) = (16usize, 16usize);
        let path = PathSettings {
            max_depth: 4,
            spectral: true,
            ..Default::default()
        };
        let run = StreamRun::new(&[Integrator::Path], &rs, Default::default());
        let ctx = test_context(&rs, &run, (w, h), path, 5);
        let mut sum = [0.0f64; 3];
        let mut n = 0u64;
        for i in 0..ctx.order.period() * 256 {
            if let Some((s, _)) = ctx.camera_sample(Integrator::Path, i, &mut Vec::new()) {
                for (c, v) in sum.iter_mut().zip(s.xyzw) {
                    *c += v as f64;
                }
                n += 1;
            }
        }
        let settings = RenderSettings {
            width: w,
            height: h,
            spp: 256,
            seed: 2,
            path,
        };
        let frame = render(&rs, &settings, &|_| {}).0;
        let mut reference = [0.0f64; 3];
        for i in 0..w * h {
            let xyz = rgb_to_xyz(Vec3::from(frame.color.rgb(i % w, i / w)));
            for (c, v) in reference.iter_mut().zip(xyz) {
                *c += v as f64 / (w * h) as f64;
            }
        }
        for c in 0..3 {
            let streamed = sum[c] / n as f64;
            assert!(
                (streamed / reference[c] - 1.0).abs() < 0.02,
                "channel {c}: stream {streamed}, spectral render {}",
                reference[c]
            );
        }
    }

    #[test]
    fn xyz_of_white_is_d65() {
        let w = rgb_to_xyz(Vec3::ONE);
        assert!((w[0] - 0.9505).abs() < 1e-3 && (w[1] - 1.0).abs() < 1e-4);
        assert!((w[2] - 1.089).abs() < 1e-3);
    }
}
