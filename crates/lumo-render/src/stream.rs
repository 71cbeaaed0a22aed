//! Samples one at a time, by index, for a progressive viewer's streams (`lumo serve`): camera
//! samples at a pixel and pass, light paths by number, and photon batches grown before the
//! camera samples that gather from them. [`Integrator::stream_camera_sample`] and
//! [`Integrator::stream_light_path`] pick the integrator's own sample from here, so the server
//! streams any integrator of the table without naming it.
//!
//! A camera sample of pixel (x, y) in pass p uses sample p of that pixel's sequence, as
//! `lumo render` does, so the streams estimate the same image.

use std::cell::Cell;

use glam::{Vec2, Vec3};

use crate::camera::PinholeCamera;
use crate::integrator::{Integrator, Particles};
use crate::integrators::bdpt::{samplers, trace_bdpt_sample, BdptScratch, BdptSettings};
use crate::integrators::light::trace_light_path;
use crate::integrators::path::{trace_path, trace_path_xyz, PathSettings};
use crate::integrators::photon::{
    trace_ppm_path, LockStats, PhotonBatch, PhotonMap, PpmSettings, RadiusSchedule,
};
use crate::render::LIGHT_STREAM_X;
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// A sample's value: linear RGB, or CIE XYZ straight from a spectral path's wavelengths.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum StreamValue {
    /// Linear sRGB.
    Rgb(Vec3),
    /// CIE XYZ.
    Xyz(Vec3),
}

/// One sample of a stream: where on the film (pixels) and its value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamSample {
    /// Film position in pixels (x right, y down).
    pub film: Vec2,
    /// Its value.
    pub value: StreamValue,
}

/// What a batch's photons cost ([`SampleStream::grow_photons`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PhotonWork {
    /// Rays traced.
    pub rays: u64,
    /// Photon paths traced.
    pub paths: u64,
}

/// The integrators that stream `parts` through `camera`: a splatting integrator falls back
/// to the path tracer's camera samples where the camera takes no splats (a thin lens, an
/// orthographic camera, a pixel filter wider than the box), each integrator once.
pub fn streamed(parts: &[Integrator], camera: &PinholeCamera) -> Vec<Integrator> {
    let splats = camera.unsupported_by_splats().is_none();
    let mut out: Vec<Integrator> = Vec::with_capacity(parts.len());
    for &p in parts {
        let p = if p.caps().splats && !splats {
            Integrator::Path
        } else {
            p
        };
        if !out.contains(&p) {
            out.push(p);
        }
    }
    out
}

/// What every thread of one progressive render shares: the photon map of an integrator that
/// gathers photons, grown batch by batch.
pub struct StreamRun {
    photons: Option<PhotonMap>,
    ppm: PpmSettings,
}

impl StreamRun {
    /// The shared state for streaming `integrators` (from [`streamed`]) over `rs`.
    pub fn new(integrators: &[Integrator], rs: &RenderScene, ppm: PpmSettings) -> Self {
        let photons = integrators
            .iter()
            .any(|i| i.caps().particles == Particles::Photons)
            .then(|| ppm.new_map(rs));
        Self { photons, ppm }
    }

    /// The photon map's lock counters (`None` without a photon map).
    pub fn lock_stats(&self) -> Option<LockStats> {
        self.photons.as_ref().map(PhotonMap::lock_stats)
    }
}

/// One thread's view of a progressive render: turns sample indices into samples.
pub struct SampleStream<'a> {
    rs: &'a RenderScene,
    camera: PinholeCamera,
    path: PathSettings,
    seed: u32,
    run: &'a StreamRun,
    /// Photon paths added before each batch of camera samples.
    photon_batch: u64,
    schedule: RadiusSchedule,
    /// The gather radius of the last pass seen (its product costs O(pass) to recompute).
    radius: Cell<(u32, f32)>,
    /// Vertex storage reused by bidirectional samples.
    scratch: Cell<BdptScratch>,
}

impl<'a> SampleStream<'a> {
    /// Samples of `rs` through `camera` with `path` and `seed`, sharing `run`. A pass has
    /// `pass_len` camera sample indices over `pixels` pixels, and a batch `batch` of them:
    /// photon mapping adds as many photon paths per camera sample as a pass of `lumo render
    /// --integrator ppm` traces per pixel, so the map grows linearly with the samples.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        rs: &'a RenderScene,
        camera: PinholeCamera,
        path: PathSettings,
        seed: u32,
        run: &'a StreamRun,
        pixels: u64,
        pass_len: u64,
        batch: u64,
    ) -> Self {
        let per_pass = run.ppm.paths_per_pass(pixels);
        Self {
            rs,
            camera,
            path,
            seed,
            run,
            photon_batch: (batch * per_pass).div_ceil(pass_len),
            schedule: run.ppm.schedule(rs, per_pass),
            radius: Cell::new((u32::MAX, 0.0)),
            scratch: Default::default(),
        }
    }

    /// Before batch `b`'s camera samples: adds its photon paths to the run's photon map
    /// (traced outside the map's lock; only the insertion takes it). `None` when `aborted`
    /// says so after the tracing; nothing to do without a photon map or lights that emit.
    pub fn grow_photons(&self, b: u64, aborted: impl Fn() -> bool) -> Option<PhotonWork> {
        let Some(map) = &self.run.photons else {
            return Some(PhotonWork::default());
        };
        if self.rs.lights.emits_no_particles() {
            return Some(PhotonWork::default());
        }
        let first = b * self.photon_batch;
        let batch = PhotonBatch::trace(
            self.rs,
            &self.path,
            self.seed,
            first..first + self.photon_batch,
        );
        if aborted() {
            return None;
        }
        map.add(&batch);
        Some(PhotonWork {
            rays: batch.rays,
            paths: batch.paths(),
        })
    }

    /// The camera sampler of pixel (x, y) in pass `pass` (past its jitter and lens point),
    /// its film position (in the pixel, where a viewer bins it) and its ray (through the
    /// point the camera's pixel filter places).
    fn camera_ray(&self, x: u32, y: u32, pass: u32) -> (PixelSampler, Vec2, Vec3, Vec3) {
        let mut sampler = PixelSampler::new(x, y, pass, self.seed);
        let jitter = sampler.next_2d();
        let corner = Vec2::new(x as f32, y as f32);
        let film = corner + jitter;
        let offset = self.camera.filter_offset((x as usize, y as usize), jitter);
        let lens = if self.camera.needs_lens_sample() {
            sampler.next_2d()
        } else {
            Vec2::splat(0.5)
        };
        let (origin, dir) = self.camera.ray(corner + offset, lens);
        (sampler, film, origin, dir)
    }

    /// The path tracer's camera sample (XYZ under spectral transport) and its rays.
    pub fn path_sample(&self, x: u32, y: u32, pass: u32) -> (StreamSample, u32) {
        let (mut sampler, film, origin, dir) = self.camera_ray(x, y, pass);
        if self.path.spectral {
            let (xyz, rays) = trace_path_xyz(self.rs, origin, dir, &mut sampler, &self.path);
            let value = StreamValue::Xyz(xyz);
            return (StreamSample { film, value }, rays);
        }
        let r = trace_path(self.rs, origin, dir, &mut sampler, &self.path, None);
        let value = StreamValue::Rgb(r.direct + r.indirect);
        (StreamSample { film, value }, r.rays)
    }

    /// Photon mapping's camera sample: gathers from the run's photon map (under its read
    /// lock, held for this one sample so photon writers wait at most one gather) at the
    /// pass's radius. `None` without a photon map.
    pub fn ppm_sample(&self, x: u32, y: u32, pass: u32) -> Option<(StreamSample, u32)> {
        let map = self.run.photons.as_ref()?;
        let (mut sampler, film, origin, dir) = self.camera_ray(x, y, pass);
        if self.radius.get().0 != pass {
            self.radius.set((pass, self.schedule.radius(pass)));
        }
        let radius = self.radius.get().1;
        let m = map.read();
        let (r, st) = trace_ppm_path(self.rs, &m, radius, origin, dir, &mut sampler, &self.path);
        drop(m);
        let value = StreamValue::Rgb(r.direct + r.indirect);
        Some((StreamSample { film, value }, st.rays))
    }

    /// A bidirectional sample: its pixel's strategies as a camera sample, its light vertices
    /// seen by the camera passed to `light` (the sample's light subpath counts as one light
    /// path of the light stream).
    pub fn bdpt_sample(
        &self,
        x: u32,
        y: u32,
        pass: u32,
        light: &mut impl FnMut(StreamSample),
    ) -> (StreamSample, u32) {
        let (mut cs, mut ls) = samplers(x, y, pass, self.seed);
        let film = Vec2::new(x as f32, y as f32) + cs.next_2d();
        let settings = BdptSettings {
            path: self.path,
            only: None,
        };
        let mut scratch = self.scratch.take();
        let r = trace_bdpt_sample(
            self.rs,
            &self.camera,
            film,
            &mut cs,
            &mut ls,
            &settings,
            &mut scratch,
            &mut |s| {
                light(StreamSample {
                    film: s.film,
                    value: StreamValue::Rgb(s.value),
                })
            },
        );
        self.scratch.set(scratch);
        let value = StreamValue::Rgb(r.direct + r.indirect);
        (StreamSample { film, value }, r.rays)
    }

    /// Light path `m` of the light tracer: its splats go to `out`; returns its rays.
    pub fn light_path(&self, m: u64, out: &mut impl FnMut(StreamSample)) -> u32 {
        let block = (m >> 16) as u32;
        let mut sampler = PixelSampler::new(LIGHT_STREAM_X, block, (m & 0xffff) as u32, self.seed);
        let stats = trace_light_path(self.rs, &self.camera, &mut sampler, &self.path, &mut |s| {
            out(StreamSample {
                film: s.film,
                value: StreamValue::Rgb(s.value),
            })
        });
        stats.rays
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each integrator's stream entry points answer exactly as its capabilities say, and
    /// with samples on the film: a row that claims a stream without its sample, or the
    /// reverse, fails here.
    #[test]
    fn every_integrator_streams_as_its_row_says() {
        let rs = RenderScene::new(lumo_scene::builtin_scene("cornell").expect("builtin"))
            .expect("scene");
        let (w, h) = (8u32, 8u32);
        for i in Integrator::ALL {
            let camera = PinholeCamera::new(&rs.scene.camera, w as usize, h as usize);
            assert_eq!(
                streamed(&[i], &camera),
                [i],
                "a pinhole takes every integrator"
            );
            let run = StreamRun::new(&[i], &rs, PpmSettings::default());
            let stream = SampleStream::new(
                &rs,
                camera,
                PathSettings::default(),
                1,
                &run,
                (w * h) as u64,
                (w * h) as u64,
                16,
            );
            assert!(stream.grow_photons(0, || false).is_some());
            let caps = i.caps();
            let mut light = Vec::new();
            let mut camera_samples = 0;
            for n in 0..w * h {
                let s = i.stream_camera_sample(&stream, n % w, n / w, 0, &mut |s| light.push(s));
                assert_eq!(s.is_some(), caps.camera_stream, "{i:?}");
                if let Some((s, _)) = s {
                    assert!(s.film.cmpge(Vec2::ZERO).all() && s.film.x < w as f32);
                    camera_samples += 1;
                }
            }
            let mut splats = 0;
            for m in 0..64 {
                let rays = i.stream_light_path(&stream, m, &mut |_| splats += 1);
                assert_eq!(rays.is_some(), i.streams_light_paths(), "{i:?}");
            }
            assert_eq!(camera_samples > 0, caps.camera_stream, "{i:?}");
            // Light reaches the camera in the Cornell box from either stream that carries it.
            assert_eq!(
                !light.is_empty() || splats > 0,
                caps.light_stream,
                "{i:?}: light stream"
            );
        }
    }

    /// A thin lens takes no splats: the splatting integrators stream as the path tracer,
    /// once each.
    #[test]
    fn splatting_integrators_fall_back_to_the_path_tracer_through_a_thin_lens() {
        let mut cam = lumo_scene::builtin_scene("cornell")
            .expect("builtin")
            .camera;
        cam.lens = lumo_scene::Lens::Thin {
            aperture_radius: 0.05,
            focus_distance: 3.0,
        };
        let camera = PinholeCamera::new(&cam, 8, 8);
        assert_eq!(
            streamed(&[Integrator::Path, Integrator::Light], &camera),
            [Integrator::Path]
        );
        assert_eq!(streamed(&[Integrator::Bdpt], &camera), [Integrator::Path]);
        assert_eq!(streamed(&[Integrator::Ppm], &camera), [Integrator::Ppm]);
    }
}
