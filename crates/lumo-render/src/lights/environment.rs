//! Image-based environment light: a latitude-longitude map in Mitsuba's orientation, sampled by
//! rows then columns in proportion to the interpolated radiance it reaches.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_image::luminance;
use lumo_scene::EnvMap;

use super::distribution::Distribution1d;
use super::source::LightSource;
use super::{EmissionPdf, EmissionSample, LightSample, Lights};
use crate::geometry::uniform_sphere_map;

/// An importance-sampled latitude-longitude environment.
pub(super) struct EnvSampler {
    pub(super) map: EnvMap,
    rows: Distribution1d,
    columns: Vec<Distribution1d>,
}

/// The world direction at map coordinates `uv`.
fn lat_long_direction(map: &EnvMap, uv: Vec2) -> Vec3 {
    // Mitsuba's envmap convention: u = atan2(x, -z)/2π, v = acos(y)/π in the map's own frame.
    let (phi, theta) = (uv.x * 2.0 * PI, uv.y * PI);
    let local = Vec3::new(
        theta.sin() * phi.sin(),
        theta.cos(),
        -theta.sin() * phi.cos(),
    );
    map.to_world.transform_vector3(local).normalize()
}

/// The map coordinates of world direction `dir` (the inverse of [`lat_long_direction`]).
fn lat_long_uv(map: &EnvMap, dir: Vec3) -> Vec2 {
    let local = map.to_world.inverse().transform_vector3(dir).normalize();
    let mut u = local.x.atan2(-local.z) / (2.0 * PI);
    if u < 0.0 {
        u += 1.0;
    }
    Vec2::new(u, local.y.clamp(-1.0, 1.0).acos() / PI)
}

impl EnvSampler {
    pub(super) fn new(map: &EnvMap) -> Self {
        let img = &map.image;
        let (w, h) = (img.width, img.height);
        let mut row_weights = Vec::with_capacity(h);
        let mut columns = Vec::with_capacity(h);
        let lum = |x: usize, y: usize| luminance(img.rgb(x % w, y)).max(0.0);
        for y in 0..h {
            let sin_theta = ((y as f32 + 0.5) / h as f32 * PI).sin();
            // Cell (x, y) of the sampling grid is lit by every texel its bilinear lookup
            // ([`EnvSampler::radiance`]) can reach: columns x−1..=x+1, and the rows that
            // v·(h−1) spans over the cell. Their largest luminance keeps the density positive
            // wherever the interpolated radiance is.
            let (r0, r1) = (
                (y * (h - 1)) / h,
                ((y + 1) * (h - 1)).div_ceil(h).min(h - 1),
            );
            let weights: Vec<f32> = (0..w)
                .map(|x| {
                    let mut m = 0.0f32;
                    for r in r0..=r1 {
                        for c in [x + w - 1, x, x + 1] {
                            m = m.max(lum(c, r));
                        }
                    }
                    m * sin_theta
                })
                .collect();
            let d = Distribution1d::new(&weights);
            row_weights.push(weights.iter().sum::<f32>());
            columns.push(d);
        }
        EnvSampler {
            map: map.clone(),
            rows: Distribution1d::new(&row_weights),
            columns,
        }
    }

    /// The map's radiance towards `-dir`, interpolated as Mitsuba 3's `envmap` does: bilinear
    /// between texel centres along u (wrapping around), between rows placed from pole to pole
    /// (row 0 at v = 0, row h−1 at v = 1) along v.
    pub(super) fn radiance(&self, dir: Vec3) -> Vec3 {
        let uv = lat_long_uv(&self.map, dir);
        let img = &self.map.image;
        let (w, h) = (img.width, img.height);
        if w == 0 || h == 0 {
            return Vec3::ZERO;
        }
        let fx = uv.x * w as f32 - 0.5;
        let x0 = fx.floor();
        let tx = fx - x0;
        let c0 = (x0 as i64).rem_euclid(w as i64) as usize;
        let c1 = (c0 + 1) % w;
        let (r0, r1, ty) = if h < 2 {
            (0, 0, 0.0)
        } else {
            let fy = (uv.y * (h - 1) as f32).clamp(0.0, (h - 1) as f32);
            let r0 = (fy as usize).min(h - 2);
            (r0, r0 + 1, fy - r0 as f32)
        };
        let px = |x: usize, y: usize| Vec3::from(img.rgb(x, y));
        let top = px(c0, r0) * (1.0 - tx) + px(c1, r0) * tx;
        let bottom = px(c0, r1) * (1.0 - tx) + px(c1, r1) * tx;
        (top * (1.0 - ty) + bottom * ty) * self.map.scale
    }

    pub(super) fn pdf(&self, dir: Vec3) -> f32 {
        let uv = lat_long_uv(&self.map, dir);
        let (w, h) = (self.map.image.width, self.map.image.height);
        let x = ((uv.x * w as f32) as usize).min(w - 1);
        let y = ((uv.y * h as f32) as usize).min(h - 1);
        let sin_theta = (uv.y * PI).sin();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let p = self.rows.pmf(y) * self.columns[y].pmf(x);
        p * (w * h) as f32 / (2.0 * PI * PI * sin_theta)
    }

    pub(super) fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let (y, uy) = self.rows.sample(u.y);
        let (x, ux) = self.columns[y].sample(u.x);
        let (w, h) = (self.map.image.width, self.map.image.height);
        let uv = Vec2::new((x as f32 + ux) / w as f32, (y as f32 + uy) / h as f32);
        let dir = lat_long_direction(&self.map, uv);
        (dir, self.pdf(dir))
    }
}

/// The environment as one light: the constant background and/or the image (whose tables live
/// in [`Lights`], shared with the radiance lookups of escaping rays).
pub(crate) struct EnvironmentLight {
    /// Mean radiance of the image times its scale, plus the constant background: its power
    /// estimate.
    pub(super) mean: Vec3,
}

impl LightSource for EnvironmentLight {
    fn power(&self, disk: f32) -> f32 {
        disk * PI * luminance(self.mean.into())
    }

    fn is_delta(&self) -> bool {
        false
    }

    /// A particle from infinity needs a scene-sized disk per direction: the environment stays
    /// the path tracer's job.
    fn emits_particles(&self) -> bool {
        false
    }

    #[inline(always)]
    fn sample_from(
        &self,
        lights: &Lights,
        light: u32,
        pick: f32,
        _p: Vec3,
        u: Vec2,
    ) -> Option<LightSample> {
        let (wi, _) = match (&lights.env, lights.constant.max_element() > 0.0) {
            (Some(e), true) => {
                // Split the 2-D point: first coordinate decides the mixture component.
                if u.x < 0.5 {
                    e.sample(Vec2::new(u.x * 2.0, u.y))
                } else {
                    let d = uniform_sphere_map(u.x * 2.0 - 1.0, u.y);
                    (Vec3::from(d), 0.0)
                }
            }
            (Some(e), false) => e.sample(u),
            // The constant background alone: the uniform direction the vector bounce's lanes
            // draw too (`uniform_sphere_map`, the same bits).
            (None, _) => (Vec3::from(uniform_sphere_map(u.x, u.y)), 0.0),
        };
        let pdf = pick * lights.env_direction_pdf(wi);
        if pdf <= 0.0 {
            return None;
        }
        Some(LightSample {
            light,
            normal: Vec3::ZERO,
            wi,
            distance: f32::INFINITY,
            point: Vec3::ZERO,
            weight: lights.environment(wi) / pdf,
            pdf,
        })
    }

    /// The density of the direction from `from` towards `point`.
    fn pdf_from(&self, lights: &Lights, pick: f32, from: Vec3, point: Vec3) -> f32 {
        pick * lights.env_direction_pdf((point - from).normalize_or_zero())
    }

    fn emit(
        &self,
        _lights: &Lights,
        _light: u32,
        _pick: f32,
        _u_pos: Vec2,
        _u_dir: Vec2,
    ) -> Option<EmissionSample> {
        None
    }

    fn emission_pdf(
        &self,
        _lights: &Lights,
        _pick: f32,
        _n: Vec3,
        _dir: Vec3,
    ) -> Option<EmissionPdf> {
        None
    }
}
