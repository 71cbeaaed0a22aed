//! Renders whole images: runs each integrator for every pixel and sample, rows (or blocks of
//! light paths, or photon batches) in parallel. With `parallel.rs` it is the only place in
//! the crate that knows about threads; `integrator.rs` chooses among these loops.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::{Vec2, Vec3};
use lumo_image::Image;
use rayon::prelude::*;

use crate::camera::PinholeCamera;
use crate::camera_sample::camera_sample;
use crate::film::Frame;
use crate::integrators::path::wavefront::{
    estimate, render_pixel_sums, render_pixels, render_pixels_into,
};
use crate::integrators::path::{trace_path, FirstHit, PathRadiance};
use crate::parallel::{fill_rows, map_rows};
use crate::pixel_sums::PixelSums;
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;
use crate::settings::{PixelEstimate, RenderSettings, RenderStats};

/// Traces camera sample `index` of pixel (x, y): sample 0 goes through the pixel centre (the
/// guided-filter paper's guide ray, §3.2), the others through a jittered point. Returns the
/// path's radiance and the sample's offset inside the pixel. `first` receives the first hit.
pub fn trace_sample(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    (x, y): (usize, usize),
    index: u32,
    first: Option<&mut FirstHit>,
) -> (PathRadiance, Vec2) {
    let (mut sampler, offset, origin, dir) = camera_sample(camera, (x, y), index, settings.seed);
    let r = trace_path(rs, origin, dir, &mut sampler, &settings.path, first);
    (r, offset)
}

/// Renders samples `0..spp` of pixel (x, y): a pure function of its arguments. The paths go
/// through the wavefront renderer, sixteen rays per packet; rendering whole rows with
/// [`render_pixels`](crate::integrators::path::wavefront::render_pixels) keeps the packets fuller.
pub fn render_pixel(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    x: usize,
    y: usize,
) -> PixelEstimate {
    render_pixels(rs, camera, settings, y, x..x + 1)
        .pop()
        .unwrap_or_default()
}

/// [`render_pixel`] one ray at a time ([`trace_sample`] per sample): the reference the
/// wavefront renderer is tested against, bit for bit.
pub fn render_pixel_one_ray(
    rs: &RenderScene,
    camera: &PinholeCamera,
    settings: &RenderSettings,
    x: usize,
    y: usize,
) -> PixelEstimate {
    let mut first_hit = FirstHit::default();
    let radiance: Vec<PathRadiance> = (0..settings.spp)
        .map(|i| {
            let first = (i == 0).then_some(&mut first_hit);
            trace_sample(rs, camera, settings, (x, y), i, first).0
        })
        .collect();
    estimate(radiance.into_iter(), first_hit)
}

/// The exact sums ([`PixelSums`]) of camera samples `first..first + count` of every pixel of
/// the frame `settings` describes (its `spp` is ignored), row-major, rows in parallel. Sums of
/// disjoint sample ranges add up, bit for bit, to the sums of their union, so a frame may be
/// rendered in chunks anywhere and added up in any order (lumo's Python package and its Ray
/// cluster renderer do); `progress` gets the fraction of rows finished.
pub fn render_sums(
    rs: &RenderScene,
    settings: &RenderSettings,
    first: u32,
    count: u32,
    progress: &(dyn Fn(f32) + Sync),
) -> Vec<PixelSums> {
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let chunk = RenderSettings {
        spp: count,
        ..*settings
    };
    let rows = |done: usize| progress(done as f32 / h.max(1) as f32);
    // Whole rows through the wavefront renderer: packets of many pixels' paths stay full.
    map_rows(h, &rows, |y| {
        render_pixel_sums(rs, &camera, &chunk, first, y, 0..w)
    })
}

/// The estimates of samples `0..spp` of every pixel of the frame `settings` describes,
/// row-major, rows in parallel: the same values as [`render_sums`]' sums turned into estimates
/// (and [`render`]'s), written straight into one frame-sized vector. Without the sums (a
/// pixel's is ~300 bytes: an 84 MB array at 512², always fresh memory from the kernel) and
/// without row vectors, a frame touches a third of the memory it did. `progress` gets the
/// fraction of rows finished.
pub fn render_estimates(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(f32) + Sync),
) -> Vec<PixelEstimate> {
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let mut out = vec![PixelEstimate::default(); w * h];
    let rows = |done: usize| progress(done as f32 / h.max(1) as f32);
    fill_rows(&mut out, w, &rows, |y, row| {
        render_pixels_into(rs, &camera, settings, y, 0..w, row)
    });
    out
}

/// The instance that each pixel centre's camera ray hits first (`u32::MAX` where it hits
/// nothing), row-major: the object-id plane of the G-buffer, whose rays go through the pixel
/// centres as well. Temporal filtering follows moving instances with it.
pub fn instance_ids(
    rs: &RenderScene,
    camera: &PinholeCamera,
    width: usize,
    height: usize,
) -> Vec<u32> {
    crate::pixel_hits(rs, camera, width, height)
        .into_iter()
        .map(|hit| hit.instance)
        .collect()
}

/// Renders the full frame. `progress` is called with the number of rows finished so far.
pub fn render(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(usize) + Sync),
) -> (Frame, RenderStats) {
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let estimates = map_rows(h, progress, |y| {
        render_pixels(rs, &camera, settings, y, 0..w)
    });
    let frame = frame_from_estimates(w, h, settings.spp, &estimates);
    let stats = RenderStats {
        samples: (w * h) as u64 * settings.spp as u64,
        rays: estimates.iter().map(|e| e.rays).sum(),
    };
    (frame, stats)
}

/// Assembles a frame from row-major per-pixel estimates of `spp` samples each.
pub fn frame_from_estimates(w: usize, h: usize, spp: u32, estimates: &[PixelEstimate]) -> Frame {
    let mut frame = Frame {
        spp,
        color: Image::new(w, h, 3, 0.0),
        direct: Image::new(w, h, 3, 0.0),
        indirect: Image::new(w, h, 3, 0.0),
        albedo: Image::new(w, h, 3, 0.0),
        normal: Image::new(w, h, 3, 0.0),
        position: Image::new(w, h, 3, 0.0),
        depth: Image::new(w, h, 1, 0.0),
        variance: Image::new(w, h, 1, 0.0),
        emission: Image::new(w, h, 3, 0.0),
        emitted: Image::new(w, h, 3, 0.0),
    };
    for (i, e) in estimates.iter().enumerate() {
        let (x, y) = (i % w, i / w);
        let put = |img: &mut Image, v: Vec3| img.pixel_mut(x, y).copy_from_slice(&v.to_array());
        put(&mut frame.direct, e.direct);
        put(&mut frame.indirect, e.indirect);
        put(&mut frame.color, e.direct + e.indirect);
        put(&mut frame.albedo, e.first_hit.albedo);
        put(&mut frame.emission, e.first_hit.emitted);
        put(&mut frame.emitted, e.emitted);
        put(&mut frame.normal, e.first_hit.normal);
        put(&mut frame.position, e.first_hit.position);
        frame.depth.pixel_mut(x, y)[0] = e.first_hit.depth;
        frame.variance.pixel_mut(x, y)[0] = e.luminance_variance / spp.max(1) as f32;
    }
    frame
}

/// The sampler's "pixel x" of light path `m` (with y = m >> 16, index = m & 0xffff): far from
/// any image's pixels, so light paths never reuse a camera sample's numbers. `lumo render
/// --integrator light` and the server's light stream draw the same numbers for path `m`.
pub const LIGHT_STREAM_X: u32 = 0x4c49_4748;

/// Light-traces an image: `width × height × spp` light paths (the same work as `spp` camera
/// samples per pixel), each vertex splatted onto the film, `pixel = Σ splats / paths`.
/// Environment lights emit no particles (see [`crate::lights::Lights::sample_emission`]).
///
/// Paths run in fixed blocks (at most 64, fixed by the image size and spp), as many blocks at
/// a time as there are threads, and the blocks' images are added in block order: the image is
/// the same bits on any number of threads. `progress` receives the fraction of paths traced.
pub fn render_light(
    rs: &RenderScene,
    settings: &RenderSettings,
    progress: &(dyn Fn(f32) + Sync),
) -> (Image, RenderStats) {
    use crate::integrators::light::trace_light_path;
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let paths = (w * h) as u64 * settings.spp as u64;
    // At most 64 blocks, so merging their images costs at most 64 additions per pixel, next
    // to paths that cost thousands of instructions; the block count depends on the work only.
    let block = paths.div_ceil(64).max(1 << 14);
    let blocks = paths.div_ceil(block);
    // Blocks in flight at once (each holds an image); changes speed, not the result.
    let wave = rayon::current_num_threads().max(1) as u64;
    let mut film = vec![[0.0f64; 3]; w * h];
    let mut rays = 0u64;
    for first in (0..blocks).step_by(wave as usize) {
        let images: Vec<(Vec<Vec3>, u64)> = (first..(first + wave).min(blocks))
            .into_par_iter()
            .map(|b| {
                let mut img = vec![Vec3::ZERO; w * h];
                let mut rays = 0u64;
                for m in b * block..((b + 1) * block).min(paths) {
                    let mut sampler = PixelSampler::new(
                        LIGHT_STREAM_X,
                        (m >> 16) as u32,
                        (m & 0xffff) as u32,
                        settings.seed,
                    );
                    let stats =
                        trace_light_path(rs, &camera, &mut sampler, &settings.path, &mut |s| {
                            let (x, y) = (s.film.x as usize, s.film.y as usize);
                            if x < w && y < h {
                                img[y * w + x] += s.value;
                            }
                        });
                    rays += stats.rays as u64;
                }
                (img, rays)
            })
            .collect();
        for (img, r) in images {
            for (f, v) in film.iter_mut().zip(img) {
                for (c, x) in f.iter_mut().zip(v.to_array()) {
                    *c += x as f64;
                }
            }
            rays += r;
        }
        progress(((first + wave).min(blocks)) as f32 / blocks.max(1) as f32);
    }
    let scale = 1.0 / paths.max(1) as f64;
    let data = film
        .iter()
        .flat_map(|p| p.map(|c| (c * scale) as f32))
        .collect();
    let stats = RenderStats {
        samples: paths,
        rays,
    };
    (Image::from_vec(w, h, 3, data), stats)
}

/// The splats of one block of rows ([`render_bdpt`]): a list while it is short (most blocks:
/// a few splats per sample), a film of the whole image once the list would outgrow one.
enum BlockSplats {
    /// Pixel index and value, in the order the block made them.
    List(Vec<(u32, Vec3)>),
    /// A whole-image film.
    Film(Vec<Vec3>),
}

impl BlockSplats {
    /// Adds `value` at pixel `index` of a `pixels`-pixel image.
    #[inline]
    fn add(&mut self, index: usize, value: Vec3, pixels: usize) {
        match self {
            BlockSplats::List(list) if list.len() < pixels => list.push((index as u32, value)),
            BlockSplats::List(list) => {
                let mut film = vec![Vec3::ZERO; pixels];
                for &(i, v) in list.iter() {
                    film[i as usize] += v;
                }
                film[index] += value;
                *self = BlockSplats::Film(film);
            }
            BlockSplats::Film(film) => film[index] += value,
        }
    }

    /// Adds the splats into `acc` (f64 per channel), in the block's own order.
    fn add_to(&self, acc: &mut [[f64; 3]]) {
        let add = |a: &mut [f64; 3], v: Vec3| {
            for (c, x) in a.iter_mut().zip(v.to_array()) {
                *c += x as f64;
            }
        };
        match self {
            BlockSplats::List(list) => list.iter().for_each(|&(i, v)| add(&mut acc[i as usize], v)),
            BlockSplats::Film(film) => acc.iter_mut().zip(film).for_each(|(a, &v)| add(a, v)),
        }
    }
}

/// Renders with bidirectional path tracing: `spp` samples per pixel, each a camera and a
/// light subpath joined by every strategy ([`crate::integrators::bdpt`]). The returned
/// image is each pixel's sample mean plus the light vertices splatted into it divided by
/// the number of samples of the whole image.
///
/// Rows run in fixed blocks (at most 64); each block keeps its own splats (a list, or a film
/// when the list grows past the image's size), added into the image in block order, so the
/// result is the same bits on any number of threads. Blocks run in waves sized to keep the
/// waiting splat lists near 256 MB (usually one wave: no barrier between blocks).
/// `progress` receives the fraction of rows done.
pub fn render_bdpt(
    rs: &RenderScene,
    settings: &RenderSettings,
    bdpt: &crate::integrators::bdpt::BdptSettings,
    progress: &(dyn Fn(f32) + Sync),
) -> (Image, RenderStats) {
    use crate::integrators::bdpt::{trace_bdpt_samples, BdptScratch, GROUP, LIGHT_SUBPATH_SEED};
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let rows_per_block = h.div_ceil(64).max(1);
    let blocks = h.div_ceil(rows_per_block);
    // About three splats of 16 bytes per sample, or a film of 12 bytes per pixel.
    let block_bytes = (rows_per_block * w * settings.spp.max(1) as usize * 48).min(w * h * 12);
    let wave = (256usize << 20)
        .checked_div(block_bytes.max(1))
        .unwrap_or(blocks)
        .max(rayon::current_num_threads())
        .max(1);
    let done = AtomicU64::new(0);
    let mut pixels = vec![Vec3::ZERO; w * h];
    let mut splats = vec![[0.0f64; 3]; w * h];
    let mut rays = 0u64;
    for first in (0..blocks).step_by(wave) {
        let results: Vec<(Vec<Vec3>, BlockSplats, u64)> = (first..(first + wave).min(blocks))
            .into_par_iter()
            .map(|b| {
                let rows = b * rows_per_block..((b + 1) * rows_per_block).min(h);
                let mut own = Vec::with_capacity(rows.len() * w);
                let mut film = BlockSplats::List(Vec::new());
                let mut scratch = BdptScratch::default();
                let mut rays = 0u64;
                let spp = settings.spp as usize;
                let mut sums = vec![Vec3::ZERO; w];
                let mut out = [PathRadiance::default(); GROUP];
                let blank = PixelSampler::new(0, 0, 0, 0);
                let mut pairs = [(blank, blank); GROUP];
                let (mut cams, mut lights) = ([blank; GROUP], [blank; GROUP]);
                for y in rows {
                    sums.fill(Vec3::ZERO);
                    // The row's samples, pixel by pixel and in index order within a pixel,
                    // a group (one ray packet per subpath step) at a time.
                    let count = w * spp;
                    for first in (0..count).step_by(GROUP) {
                        let n = GROUP.min(count - first);
                        let mut films = [Vec2::ZERO; GROUP];
                        // The group's samplers (`samplers`' pairs), sixteen at a time in
                        // vector lanes (the same bits as one at a time).
                        let mut triples = [(0, 0, 0); GROUP];
                        for (k, tr) in triples[..n].iter_mut().enumerate() {
                            let (x, i) = ((first + k) / spp, (first + k) % spp);
                            *tr = (x as u32, y as u32, i as u32);
                        }
                        PixelSampler::run(&triples[..n], settings.seed, &mut cams[..n]);
                        let light_seed = settings.seed ^ LIGHT_SUBPATH_SEED;
                        PixelSampler::run(&triples[..n], light_seed, &mut lights[..n]);
                        for k in 0..n {
                            let jitter = cams[k].next_2d();
                            films[k] = Vec2::new(triples[k].0 as f32, y as f32) + jitter;
                            pairs[k] = (cams[k], lights[k]);
                        }
                        trace_bdpt_samples(
                            rs,
                            &camera,
                            &films[..n],
                            &mut pairs[..n],
                            bdpt,
                            &mut scratch,
                            &mut out[..n],
                            &mut |_, s| {
                                let (sx, sy) = (s.film.x as usize, s.film.y as usize);
                                if sx < w && sy < h {
                                    film.add(sy * w + sx, s.value, w * h);
                                }
                            },
                        );
                        for (k, r) in out[..n].iter().enumerate() {
                            sums[(first + k) / spp] += r.direct + r.indirect;
                            rays += r.rays as u64;
                        }
                    }
                    own.extend(sums.iter().map(|&sum| sum / settings.spp.max(1) as f32));
                }
                let n = done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(n as f32 / blocks.max(1) as f32);
                (own, film, rays)
            })
            .collect();
        for (k, (own, film, r)) in results.into_iter().enumerate() {
            let start = (first + k) * rows_per_block * w;
            pixels[start..start + own.len()].copy_from_slice(&own);
            film.add_to(&mut splats);
            rays += r;
        }
    }
    let samples = (w * h) as u64 * settings.spp as u64;
    let scale = 1.0 / samples.max(1) as f64;
    let data = pixels
        .iter()
        .zip(&splats)
        .flat_map(|(p, s)| {
            let a = p.to_array();
            [0, 1, 2].map(|c| (a[c] as f64 + s[c] * scale) as f32)
        })
        .collect();
    (
        Image::from_vec(w, h, 3, data),
        RenderStats { samples, rays },
    )
}

/// Counters of a photon-mapping render ([`render_ppm`]).
#[derive(Clone, Copy, Debug, Default)]
pub struct PpmStats {
    /// Camera samples traced.
    pub samples: u64,
    /// Rays traced by camera and photon paths.
    pub rays: u64,
    /// Photon paths traced.
    pub photon_paths: u64,
    /// Photons in the map at the end.
    pub photons_stored: u64,
    /// Most photons the map held at once.
    pub peak_photons: u64,
    /// Times the map was emptied to stay within `max_photons`.
    pub generations: u32,
    /// Photons that contributed to some camera sample, summed over samples.
    pub photons_gathered: u64,
    /// Seconds spent tracing and inserting photons (the rest is camera passes).
    pub photon_seconds: f64,
    /// The map's lock counters.
    pub lock: crate::integrators::photon::LockStats,
}

/// Photon paths per parallel task of a photon batch: fixed, so the batch (and the order its
/// photons enter the map) does not depend on the thread count.
const PHOTON_BLOCK: u64 = 2048;

/// Blocks traced in parallel before the batch is checked against the map's capacity: enough
/// to keep every thread busy, few enough that a pass far larger than the map stops early.
const PHOTON_CHUNK_BLOCKS: u64 = 64;

/// Renders with one-pass progressive photon mapping: `spp` passes, each first tracing a
/// batch of photon paths (`ppm.photons_per_pass`, by default one per pixel) into the shared
/// map, then camera sample `k` of every pixel gathering from it at pass `k`'s radius; the
/// image is the mean of the passes.
///
/// Photon paths run in parallel in fixed blocks whose photons enter the map in path order
/// (a pass stops tracing once it holds more photons than the map can keep), and each camera
/// sample is a pure function of the map and its pixel: the image is the same
/// bits on any number of threads. `progress` receives the fraction of passes done.
pub fn render_ppm(
    rs: &RenderScene,
    settings: &RenderSettings,
    ppm: &crate::integrators::photon::PpmSettings,
    progress: &(dyn Fn(f32) + Sync),
) -> (Image, PpmStats) {
    use crate::integrators::photon::{trace_ppm_path, PhotonBatch};
    use std::time::Instant;
    let (w, h) = (settings.width, settings.height);
    let camera = PinholeCamera::new(&rs.scene.camera, w, h);
    let per_pass = ppm.paths_per_pass((w * h) as u64);
    let schedule = ppm.schedule(rs, per_pass);
    let map = ppm.new_map(rs);
    let mut film = vec![[0.0f64; 3]; w * h];
    let mut stats = PpmStats::default();
    for k in 0..settings.spp {
        let t = Instant::now();
        let first = k as u64 * per_pass;
        let blocks = per_pass.div_ceil(PHOTON_BLOCK);
        let mut batch = PhotonBatch::default();
        let mut next = 0;
        while next < blocks {
            let chunk = next..(next + PHOTON_CHUNK_BLOCKS).min(blocks);
            next = chunk.end;
            let parts: Vec<PhotonBatch> = chunk
                .into_par_iter()
                .map(|b| {
                    let start = first + b * PHOTON_BLOCK;
                    let end = (start + PHOTON_BLOCK).min(first + per_pass);
                    PhotonBatch::trace(rs, &settings.path, settings.seed, start..end)
                })
                .collect();
            for p in parts {
                batch.append(p);
            }
            // The map keeps at most `max_photons` of a batch, its longest prefix of whole
            // paths that fits: past that, the pass's remaining paths could never enter it, and
            // tracing them would hold memory that --max-photons is there to bound (a pass of
            // 4294967295 paths grew by 135 MB/s). The kept photons are the same either way.
            if batch.photons.len() > ppm.max_photons {
                break;
            }
        }
        stats.rays += batch.rays;
        stats.photon_paths += batch.paths();
        map.add(&batch);
        drop(batch);
        stats.photon_seconds += t.elapsed().as_secs_f64();
        let radius = schedule.radius(k);
        let rows: Vec<(Vec3, u32, u32)> = map_rows(h, &|_| {}, |y| {
            // One read lock per row: no writer runs during a camera pass, so it never waits.
            let m = map.read();
            (0..w)
                .map(|x| {
                    let (mut sampler, _, origin, dir) =
                        camera_sample(&camera, (x, y), k, settings.seed);
                    let (r, st) =
                        trace_ppm_path(rs, &m, radius, origin, dir, &mut sampler, &settings.path);
                    (r.direct + r.indirect, st.rays, st.photons)
                })
                .collect()
        });
        for (f, (c, rays, photons)) in film.iter_mut().zip(rows) {
            for (a, v) in f.iter_mut().zip(c.to_array()) {
                // A NaN from one degenerate sample must not poison the pixel.
                if v.is_finite() {
                    *a += v as f64;
                }
            }
            stats.rays += rays as u64;
            stats.photons_gathered += photons as u64;
        }
        {
            let m = map.read();
            stats.peak_photons = stats.peak_photons.max(m.tree.len() as u64);
            stats.photons_stored = m.tree.len() as u64;
            stats.generations = m.generation;
        }
        progress((k + 1) as f32 / settings.spp.max(1) as f32);
    }
    stats.samples = (w * h) as u64 * settings.spp as u64;
    stats.lock = map.lock_stats();
    let scale = 1.0 / settings.spp.max(1) as f64;
    let data = film
        .iter()
        .flat_map(|p| p.map(|c| (c * scale) as f32))
        .collect();
    (Image::from_vec(w, h, 3, data), stats)
}
