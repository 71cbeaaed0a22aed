//! Distance sampling and transmittance in one medium along one ray segment.
//!
//! The lanes of every colour are the path's: R, G, B, or under spectral transport its three
//! wavelengths. Chromatic media use the one-sample balance heuristic over the lanes in path
//! space (pbrt-v4's and Mitsuba's `volpathmis` idea): a path picks one lane at its start and
//! samples homogeneous media by that lane's exponential, while recording, per lane, the ratio
//! of the density that lane's choice would have given (`Flight`'s `ratio`); the integrator
//! divides by the lanes' mean ratio, so the estimate is f / mean(p_lane) over the whole path
//! and one lane's rare events do not blow up another's weight. Grid media are tracked against
//! one majorant for all lanes (the largest lane's): every lane's technique is the same there,
//! so their ratio stays 1, and each tentative collision is a real scattering or a null
//! collision with probabilities from the path's throughput-weighted coefficients (spectral
//! tracking).

use glam::{Mat4, Vec3};
use lumo_scene::media::{Density, DensityGrid, Medium};
use lumo_spectrum::Wavelengths;

use crate::sampler::PixelSampler;

/// A medium's coefficients at a path's lanes.
#[derive(Clone, Copy, Debug)]
pub struct Coefficients {
    /// Extinction per unit length (per unit density for grids).
    pub sigma_t: Vec3,
    /// Single-scattering albedo.
    pub albedo: Vec3,
}

impl Coefficients {
    /// `medium`'s coefficients in RGB, or at the wavelengths `wl`.
    pub fn of(medium: &Medium, wl: Option<&Wavelengths>) -> Self {
        match wl {
            None => Coefficients {
                sigma_t: medium.sigma_t,
                albedo: medium.albedo,
            },
            Some(wl) => {
                let at =
                    |t: &lumo_spectrum::Tabulated| Vec3::from_array(wl.lambda.map(|l| t.eval(l)));
                let sp = &medium.spectra;
                // A tabulated spectrum is the file's own; an RGB value is upsampled as
                // Mitsuba's spectral variants do (extinction unbounded, albedo bounded).
                let sigma_t = match &sp.sigma_t {
                    Some(t) => at(t) * sp.sigma_t_scale,
                    None => lumo_spectrum::upsample::unbounded(medium.sigma_t, wl),
                };
                let albedo = match &sp.albedo {
                    Some(t) => at(t),
                    None => lumo_spectrum::upsample::reflectance(medium.albedo, wl),
                };
                Coefficients {
                    sigma_t: sigma_t.max(Vec3::ZERO),
                    albedo: albedo.clamp(Vec3::ZERO, Vec3::ONE),
                }
            }
        }
    }
}

/// What a free flight found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flight {
    /// A real scattering event at ray parameter `t`; `weight` multiplies the throughput
    /// (transmittance × σ_s over the sampling density).
    Scatter {
        /// Where along the ray.
        t: f32,
        /// Throughput factor: the event's contribution over its density for the path's lane.
        weight: Vec3,
        /// Per lane, the event's density had that lane been the path's, over the density it
        /// had (the path-space MIS record; 1 where all lanes sample alike).
        ratio: Vec3,
    },
    /// The ray reached `tmax` without scattering.
    Pass {
        /// Throughput factor (zero where the medium absorbed the path).
        weight: Vec3,
        /// As for [`Flight::Scatter`].
        ratio: Vec3,
    },
}

/// e^(−σ·t) with e^(−0·∞) = 1.
#[inline]
fn beer(sigma: Vec3, t: f32) -> Vec3 {
    Vec3::select(sigma.cmpgt(Vec3::ZERO), (-sigma * t).exp(), Vec3::ONE)
}

/// Samples the distance to the next real scattering along `o + t·d` (unit `d`) for
/// `0 < t < tmax` in `medium` for a path sampling by lane `lane` (0..3). `throughput` (the
/// path's) steers the scatter/null choice of chromatic grid media.
#[allow(clippy::too_many_arguments)]
pub fn free_flight(
    medium: &Medium,
    c: &Coefficients,
    o: Vec3,
    d: Vec3,
    tmax: f32,
    lane: usize,
    throughput: Vec3,
    sampler: &mut PixelSampler,
) -> Flight {
    match &medium.density {
        Density::Homogeneous => homogeneous_flight(c, tmax, lane, sampler),
        Density::Grid { grid, to_local } => {
            grid_flight(grid, to_local, c, o, d, tmax, throughput, sampler)
        }
    }
}

/// The closed form: lane `lane`'s exponential, every lane's density recorded.
fn homogeneous_flight(
    c: &Coefficients,
    tmax: f32,
    lane: usize,
    sampler: &mut PixelSampler,
) -> Flight {
    let u = sampler.next_1d();
    let s = c.sigma_t[lane];
    let t = if s > 0.0 {
        -(1.0 - u).ln() / s
    } else {
        f32::INFINITY
    };
    if t < tmax {
        let tr = beer(c.sigma_t, t);
        let pdf = c.sigma_t * tr;
        return Flight::Scatter {
            t,
            weight: c.sigma_t * c.albedo * tr / pdf[lane],
            ratio: pdf / pdf[lane],
        };
    }
    let tr = beer(c.sigma_t, tmax);
    if tr[lane] > 0.0 {
        Flight::Pass {
            weight: tr / tr[lane],
            ratio: tr / tr[lane],
        }
    } else {
        Flight::Pass {
            weight: Vec3::ZERO,
            ratio: Vec3::ONE,
        }
    }
}

/// The segments of a ray through a grid's majorant cells: ray parameters `t0..t1` and the
/// cell's largest density.
struct Segments<'a> {
    grid: &'a DensityGrid,
    /// The current cell (cell (i, j, k) spans [i, i+1)×… in cell units).
    cell: [i64; 3],
    step: [i64; 3],
    t_next: Vec3,
    t_delta: Vec3,
    t: f32,
    t_end: f32,
}

impl<'a> Segments<'a> {
    /// The segments of `o + t·d`, `0 ≤ t ≤ tmax`, inside the unit cube of `to_local`.
    fn new(grid: &'a DensityGrid, to_local: &Mat4, o: Vec3, d: Vec3, tmax: f32) -> Option<Self> {
        let ol = to_local.transform_point3(o);
        let dl = to_local.transform_vector3(d);
        // The ray against the unit cube (slabs).
        let inv = dl.recip();
        let ta = (Vec3::ZERO - ol) * inv;
        let tb = (Vec3::ONE - ol) * inv;
        let lo = ta.min(tb);
        let hi = ta.max(tb);
        let mut t0 = 0.0f32;
        let mut t1 = tmax;
        for a in 0..3 {
            if dl[a] == 0.0 {
                if !(0.0..=1.0).contains(&ol[a]) {
                    return None;
                }
            } else {
                t0 = t0.max(lo[a]);
                t1 = t1.min(hi[a]);
            }
        }
        if t0.is_nan() || t1.is_nan() || t0 >= t1 {
            return None;
        }
        let res = grid.resolution();
        let cells = grid.majorant_resolution();
        // Unit cube → cell units: cells are MAJORANT_BLOCK voxels wide.
        let scale = Vec3::new(
            res[0] as f32 / lumo_scene::media::MAJORANT_BLOCK as f32,
            res[1] as f32 / lumo_scene::media::MAJORANT_BLOCK as f32,
            res[2] as f32 / lumo_scene::media::MAJORANT_BLOCK as f32,
        );
        let q = ol * scale;
        let dq = dl * scale;
        let start = q + dq * t0;
        let mut cell = [0i64; 3];
        let mut step = [0i64; 3];
        let mut t_next = Vec3::INFINITY;
        let mut t_delta = Vec3::INFINITY;
        for a in 0..3 {
            cell[a] = (start[a].floor() as i64).clamp(0, cells[a] as i64 - 1);
            if dq[a] > 0.0 {
                step[a] = 1;
                t_next[a] = ((cell[a] + 1) as f32 - q[a]) / dq[a];
                t_delta[a] = 1.0 / dq[a];
            } else if dq[a] < 0.0 {
                step[a] = -1;
                t_next[a] = (cell[a] as f32 - q[a]) / dq[a];
                t_delta[a] = -1.0 / dq[a];
            }
        }
        Some(Segments {
            grid,
            cell,
            step,
            t_next,
            t_delta,
            t: t0,
            t_end: t1,
        })
    }
}

impl Iterator for Segments<'_> {
    type Item = (f32, f32, f32);

    fn next(&mut self) -> Option<(f32, f32, f32)> {
        let cells = self.grid.majorant_resolution();
        if self.t >= self.t_end
            || (0..3).any(|a| self.cell[a] < 0 || self.cell[a] >= cells[a] as i64)
        {
            return None;
        }
        let axis = if self.t_next.x < self.t_next.y {
            if self.t_next.x < self.t_next.z {
                0
            } else {
                2
            }
        } else if self.t_next.y < self.t_next.z {
            1
        } else {
            2
        };
        let t0 = self.t;
        let t1 = self.t_next[axis].min(self.t_end);
        let m = self.grid.majorant(
            self.cell[0] as usize,
            self.cell[1] as usize,
            self.cell[2] as usize,
        );
        self.t = t1;
        self.cell[axis] += self.step[axis];
        self.t_next[axis] += self.t_delta[axis];
        Some((t0, t1, m))
    }
}

/// An exponential step of rate `mu` from `u` in [0, 1).
#[inline]
fn exp_step(mu: f32, u: f32) -> f32 {
    -(1.0 - u).ln() / mu
}

/// Delta (spectral) tracking through the majorant cells.
#[allow(clippy::too_many_arguments)]
fn grid_flight(
    grid: &DensityGrid,
    to_local: &Mat4,
    c: &Coefficients,
    o: Vec3,
    d: Vec3,
    tmax: f32,
    throughput: Vec3,
    sampler: &mut PixelSampler,
) -> Flight {
    let mut w = Vec3::ONE;
    let ratio = Vec3::ONE;
    let sigma_max = c.sigma_t.max_element();
    if sigma_max <= 0.0 {
        return Flight::Pass { weight: w, ratio };
    }
    let Some(segments) = Segments::new(grid, to_local, o, d, tmax) else {
        return Flight::Pass { weight: w, ratio };
    };
    let sigma_s = c.sigma_t * c.albedo;
    for (t0, t1, m) in segments {
        let mu = m * sigma_max;
        if mu <= 0.0 {
            continue;
        }
        let mut t = t0;
        loop {
            t += exp_step(mu, sampler.next_1d());
            if t >= t1 {
                break;
            }
            let density = grid.density(segments_local(o, d, to_local, t));
            let st = c.sigma_t * density;
            let ss = sigma_s * density;
            let sn = (Vec3::splat(mu) - st).max(Vec3::ZERO);
            let h = throughput * w;
            let ps = (h * ss).element_sum();
            let pn = (h * sn).element_sum();
            if ps + pn <= 0.0 {
                return Flight::Pass {
                    weight: Vec3::ZERO,
                    ratio,
                };
            }
            let p_scatter = ps / (ps + pn);
            if sampler.next_1d() < p_scatter {
                return Flight::Scatter {
                    t,
                    weight: w * ss / (mu * p_scatter),
                    ratio,
                };
            }
            w *= sn / (mu * (1.0 - p_scatter));
        }
    }
    Flight::Pass { weight: w, ratio }
}

/// The unit-cube point of world ray parameter `t`.
#[inline]
fn segments_local(o: Vec3, d: Vec3, to_local: &Mat4, t: f32) -> Vec3 {
    to_local.transform_point3(o + d * t)
}

/// Transmittance of `medium` along `o + t·d`, `0 < t < tmax`: closed form when homogeneous,
/// ratio tracking (with Russian roulette once it is small) over the majorant cells of a grid.
pub fn transmittance_in(
    medium: &Medium,
    c: &Coefficients,
    o: Vec3,
    d: Vec3,
    tmax: f32,
    sampler: &mut PixelSampler,
) -> Vec3 {
    match &medium.density {
        Density::Homogeneous => beer(c.sigma_t, tmax),
        Density::Grid { grid, to_local } => {
            let sigma_max = c.sigma_t.max_element();
            let mut tr = Vec3::ONE;
            if sigma_max <= 0.0 {
                return tr;
            }
            let Some(segments) = Segments::new(grid, to_local, o, d, tmax) else {
                return tr;
            };
            for (t0, t1, m) in segments {
                let mu = m * sigma_max;
                if mu <= 0.0 {
                    continue;
                }
                let mut t = t0;
                loop {
                    t += exp_step(mu, sampler.next_1d());
                    if t >= t1 {
                        break;
                    }
                    let density = grid.density(segments_local(o, d, to_local, t));
                    tr *= (Vec3::ONE - c.sigma_t * density / mu).max(Vec3::ZERO);
                    let q = tr.max_element();
                    if q < 0.1 {
                        // Russian roulette: unbiased, and it ends walks through dense
                        // regions that would only multiply tiny numbers.
                        if sampler.next_1d() >= q {
                            return Vec3::ZERO;
                        }
                        tr /= q;
                    }
                }
            }
            tr
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_scene::PhaseFunction;
    use std::sync::Arc;

    /// A medium whose density rises linearly along its grid's x (voxel centres (i + ½)/n),
    /// constant along y and z, placed by `to_world`.
    fn ramp(n: usize, sigma_t: Vec3, albedo: Vec3, to_world: Mat4) -> Medium {
        let mut data = Vec::new();
        for _z in 0..3 {
            for _y in 0..3 {
                for i in 0..n {
                    data.push((i as f32 + 0.5) / n as f32);
                }
            }
        }
        Medium {
            name: "ramp".into(),
            sigma_t,
            albedo,
            density: Density::Grid {
                grid: Arc::new(DensityGrid::new([n, 3, 3], data).unwrap()),
                to_local: to_world.inverse(),
            },
            phase: PhaseFunction::Isotropic,
            spectra: Default::default(),
        }
    }

    /// exp(−σ ∫ density) along the ray by midpoint quadrature of the grid's own lookups.
    fn quadrature(m: &Medium, o: Vec3, d: Vec3, tmax: f32) -> Vec3 {
        let Density::Grid { grid, to_local } = &m.density else {
            unreachable!()
        };
        let steps = 200_000;
        let dt = tmax as f64 / steps as f64;
        let tau: f64 = (0..steps)
            .map(|i| {
                let t = (i as f64 + 0.5) * dt;
                grid.density(to_local.transform_point3(o + d * t as f32)) as f64 * dt
            })
            .sum();
        (-m.sigma_t * tau as f32).exp()
    }

    fn samplers(n: u32) -> impl Iterator<Item = PixelSampler> {
        (0..n).map(|i| PixelSampler::new(i % 7, i / 7, i, 11))
    }

    #[test]
    fn ramp_optical_depth_is_one_half_per_unit_sigma() {
        // The closed form: ∫₀¹ of a clamped linear ramp through the voxel centres is ½.
        let m = ramp(40, Vec3::splat(2.0), Vec3::ONE, Mat4::IDENTITY);
        let t = quadrature(&m, Vec3::new(-0.5, 0.5, 0.5), Vec3::X, 3.0);
        assert!(
            (t - Vec3::splat((-1.0f32).exp())).abs().max_element() < 1e-4,
            "{t}"
        );
    }

    #[test]
    fn ratio_tracking_matches_the_analytic_transmittance() {
        let to_world = Mat4::from_scale_rotation_translation(
            Vec3::new(2.0, 1.0, 1.5),
            glam::Quat::from_rotation_z(0.3),
            Vec3::new(0.2, -0.4, 0.1),
        );
        let m = ramp(40, Vec3::new(0.5, 1.5, 3.0), Vec3::ONE, to_world);
        let o = to_world.transform_point3(Vec3::new(-0.3, 0.4, 0.6));
        let d = to_world
            .transform_vector3(Vec3::new(1.0, 0.15, -0.1))
            .normalize();
        let c = Coefficients::of(&m, None);
        for tmax in [0.7f32, 1.6, 10.0] {
            let want = quadrature(&m, o, d, tmax);
            let n = 40_000;
            let sum: Vec3 = samplers(n)
                .map(|mut s| transmittance_in(&m, &c, o, d, tmax, &mut s))
                .sum();
            let got = sum / n as f32;
            let err = (got - want).abs().max_element();
            assert!(
                err < 0.006,
                "tmax {tmax}: ratio tracking {got}, analytic {want}"
            );
        }
    }

    #[test]
    fn delta_tracking_samples_distances_by_the_transmittance() {
        // Albedo 1, grey: every event has weight 1, so the fraction of flights passing a
        // distance is the transmittance up to it.
        let m = ramp(40, Vec3::splat(2.5), Vec3::ONE, Mat4::IDENTITY);
        let o = Vec3::new(-0.2, 0.5, 0.5);
        let c = Coefficients::of(&m, None);
        let n = 40_000;
        let mut passed = [0u32; 3];
        let marks = [0.6f32, 0.9, 1.2];
        let mut total = Vec3::ZERO;
        for mut s in samplers(n) {
            match free_flight(&m, &c, o, Vec3::X, 5.0, 0, Vec3::ONE, &mut s) {
                Flight::Scatter { t, weight, ratio } => {
                    assert!((weight - Vec3::ONE).abs().max_element() < 1e-5, "{weight}");
                    assert_eq!(ratio, Vec3::ONE);
                    for (k, &x) in marks.iter().enumerate() {
                        passed[k] += u32::from(t > x);
                    }
                }
                Flight::Pass { weight, .. } => {
                    total += weight;
                    for p in &mut passed {
                        *p += 1;
                    }
                }
            }
        }
        for (k, &x) in marks.iter().enumerate() {
            let want = quadrature(&m, o, Vec3::X, x).x;
            let got = passed[k] as f32 / n as f32;
            assert!(
                (got - want).abs() < 0.006,
                "to {x}: {got} passed, analytic {want}"
            );
        }
        let want = quadrature(&m, o, Vec3::X, 5.0).x;
        assert!((total.x / n as f32 - want).abs() < 0.006);
    }

    #[test]
    fn homogeneous_flights_follow_beer_lambert_per_lane() {
        let c = Coefficients {
            sigma_t: Vec3::new(0.5, 1.0, 2.0),
            albedo: Vec3::ZERO,
        };
        let tmax = 1.0;
        let n = 120_000;
        for lane in 0..3 {
            let mut mean = Vec3::ZERO;
            for mut s in samplers(n) {
                // Absorbing: only the passes carry weight; the path-space MIS record is the
                // weight itself here, so f / mean(p) is the pass weight over its ratio mean.
                if let Flight::Pass { weight, .. } = homogeneous_flight(&c, tmax, lane, &mut s) {
                    mean += weight;
                }
            }
            let got = mean / n as f32;
            let want = (-c.sigma_t * tmax).exp();
            assert!(
                ((got - want) / want).abs().max_element() < 0.02,
                "lane {lane}: {got} vs {want}"
            );
        }
    }
}
