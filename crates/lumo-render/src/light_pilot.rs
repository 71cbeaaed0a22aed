//! The light pilot: a short deterministic pass of camera paths that measures how much light
//! each light group delivers through next-event estimation, shadows included, so that the
//! light choice can follow what the camera sees rather than power alone
//! ([`crate::lights::Lights::select_by_groups`]).
//!
//! Power over-rates a light that lights little of what the camera sees: the atrium's sun
//! (irradiance × the scene's whole disk, ≈ 9× the emissive strips' power) reaches only the
//! patch under the roof slot, so ~90 % of its light samples found a shadow
//! (docs/results/peers.md). The pilot traces a small grid of camera paths; at each
//! non-specular vertex it samples every group once (shadow ray included) and takes the
//! luminance c of the path's throughput × BSDF × light sample weight, weighted by the power
//! heuristic against the BSDF's density as the path tracer weighs it (with the light's
//! density under the choice by power). A group's share is the sum of those: the light that
//! next-event estimation, not BSDF sampling, carries from it. Without the MIS weight a sky
//! that BSDF sampling already finds well took samples from a low sun (+37 % relMSE on
//! sun-low); by √ of the second moment (the optimum for a choice without MIS) too
//! (docs/results/peers.md, "Light selection", has the sweep). Without media and masks: the
//! shares only steer the choice, and the mixture with power keeps every light with power at a
//! non-zero probability, so no approximation here can bias an image.
//!
//! Deterministic and independent of the thread count: every random number is a function of
//! (pilot pixel, seed), rows run in parallel, and their sums are added up in row order.

use std::time::{Duration, Instant};

use glam::{Vec2, Vec3};
use lumo_image::luminance;
use rayon::prelude::*;

use crate::camera::PinholeCamera;
use crate::direct_split::shadow_ray;
use crate::geometry::power_heuristic;
use crate::lights::distribution::Distribution1d;
use crate::render_scene::RenderScene;
use crate::sampler::PixelSampler;

/// Groups sampled one by one at each vertex up to this many; past it, this many are drawn
/// uniformly (each estimate stays unbiased, a scene of many small lights stays cheap).
pub const MAX_GROUPS_PER_VERTEX: usize = 16;

/// How the pilot runs and how its shares are mixed with power.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightPilot {
    /// Paths along the image's longer side (the shorter side in proportion).
    pub grid: usize,
    /// Path vertices at which lights are sampled (1: the camera rays' first hits only).
    pub vertices: u32,
    /// Weight of power in the mixture, in (0, 1]: every light keeps at least this share of
    /// its power-proportional probability (outside that range the choice stays by power).
    pub mix: f32,
    /// Seed of the pilot's random numbers.
    pub seed: u32,
}

impl Default for LightPilot {
    /// 64 paths on the longer side, 3 vertices, 20 % power (chosen on the peer and held-out
    /// scenes: docs/results/peers.md, "Light selection").
    fn default() -> Self {
        Self {
            grid: 64,
            vertices: 3,
            mix: 0.2,
            seed: 0x9e37_79b9,
        }
    }
}

/// Per light group, what its next-event samples delivered to the pilot's paths: the sums of
/// their luminance and of its square.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PilotSums {
    /// Per group, the summed luminance (its mean light, times the number of paths).
    pub first: Vec<f64>,
    /// Per group, the summed squared luminance (its second moment, times the number of paths).
    pub second: Vec<f64>,
    /// Per group, the summed luminance weighted by the power heuristic against the BSDF's
    /// density, with the light's density under the choice the pilot ran with: the part of
    /// its light that next-event estimation, not BSDF sampling, carries.
    pub weighted: Vec<f64>,
}

impl PilotSums {
    /// All sums zero for `groups` groups.
    fn zeros(groups: usize) -> Self {
        Self {
            first: vec![0.0; groups],
            second: vec![0.0; groups],
            weighted: vec![0.0; groups],
        }
    }

    /// Adds `other`'s sums to these, group by group.
    fn add(&mut self, other: &PilotSums) {
        for (mine, theirs) in [
            (&mut self.first, &other.first),
            (&mut self.second, &other.second),
            (&mut self.weighted, &other.weighted),
        ] {
            for (t, v) in mine.iter_mut().zip(theirs) {
                *t += v;
            }
        }
    }

    /// The shares the light choice mixes in: each group's MIS-weighted light
    /// ([`PilotSums::weighted`]).
    pub fn shares(&self) -> Vec<f64> {
        self.weighted.clone()
    }
}

/// What a pilot measured and did.
#[derive(Clone, Debug)]
pub struct PilotReport {
    /// Per light group, its share ([`PilotSums::shares`]; zeros where the pilot did not run).
    pub shares: Vec<f64>,
    /// Per light group, the probability the light choice now gives it.
    pub group_pmf: Vec<f32>,
    /// Whether the choice now mixes the shares in (`false`: it stayed by power, as when the
    /// pilot saw no light or there is at most one group).
    pub applied: bool,
    /// Wall time of the pilot's paths and the new tables.
    pub time: Duration,
}

impl RenderScene {
    /// Runs the light pilot for a `width`×`height` view of the scene's camera and mixes its
    /// measured shares into the light choice. With one group or none, or where the pilot
    /// sees no light at all, the choice stays by power. The choice is kept by
    /// [`RenderScene::update`] (re-applied to the moved lights' powers) and reset by a
    /// rebuild; call again for a new measurement.
    pub fn select_lights_by_pilot(
        &mut self,
        width: usize,
        height: usize,
        pilot: &LightPilot,
    ) -> PilotReport {
        let start = Instant::now();
        let groups = self.lights.group_count();
        // Measured under the choice by power, whatever a previous pilot chose.
        self.lights.select_by_power();
        let (shares, applied) = if groups > 1 {
            let shares = measure(self, width, height, pilot).shares();
            // A refusal keeps the choice by power: nothing seen or nothing with power, or a
            // mix outside (0, 1] (see `LightPilot::mix`).
            let applied = self.lights.select_by_groups(&shares, pilot.mix).is_ok();
            (shares, applied)
        } else {
            (vec![0.0; groups], false)
        };
        PilotReport {
            shares,
            group_pmf: self.lights.group_pmf(),
            applied,
            time: start.elapsed(),
        }
    }
}

/// Per light group, what its next-event samples delivered to the pilot's paths.
pub fn measure(rs: &RenderScene, width: usize, height: usize, pilot: &LightPilot) -> PilotSums {
    let groups = rs.lights.group_count();
    let long = width.max(height).max(1) as f64;
    let gw = ((pilot.grid as f64 * width as f64 / long).round() as usize).max(1);
    let gh = ((pilot.grid as f64 * height as f64 / long).round() as usize).max(1);
    let camera = PinholeCamera::new(&rs.scene.camera, gw, gh);
    let choices = rs.lights.group_choices();
    let group_pmf = rs.lights.group_pmf();
    let rows: Vec<PilotSums> = (0..gh)
        .into_par_iter()
        .map(|y| {
            let mut sums = PilotSums::zeros(groups);
            for x in 0..gw {
                trace(
                    rs,
                    &camera,
                    (&choices, &group_pmf),
                    (x, y),
                    pilot,
                    &mut sums,
                );
            }
            sums
        })
        .collect();
    // In row order, so the sums do not depend on how rayon split the rows.
    let mut total = PilotSums::zeros(groups);
    for row in &rows {
        total.add(row);
    }
    total
}

/// One pilot path through pixel `(x, y)`, its light samples' luminance (and its square) added
/// to `sums`.
fn trace(
    rs: &RenderScene,
    camera: &PinholeCamera,
    (choices, group_pmf): (&[Distribution1d], &[f32]),
    (x, y): (usize, usize),
    pilot: &LightPilot,
    sums: &mut PilotSums,
) {
    let groups = sums.first.len();
    let mut sampler = PixelSampler::new(x as u32, y as u32, 0, pilot.seed);
    let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
    let (mut origin, mut dir) = camera.ray(film, sampler.next_2d());
    let mut throughput = Vec3::ONE;
    // Sampled one by one when few, else `MAX_GROUPS_PER_VERTEX` drawn uniformly.
    let draws = groups.min(MAX_GROUPS_PER_VERTEX);
    let scale = groups as f64 / draws as f64;
    for _ in 0..pilot.vertices {
        let Some(hit) = rs.accel.intersect(origin, dir, 0.0, f32::INFINITY) else {
            return;
        };
        let s = rs.surface(&hit, origin, dir);
        let bsdf = rs.bsdf(&s);
        let wo = s.frame.to_local(-dir);
        if !bsdf.is_delta() {
            for k in 0..draws {
                let g = if draws == groups {
                    k
                } else {
                    ((sampler.next_1d() * groups as f32) as usize).min(groups - 1)
                };
                let (uc, u) = (sampler.next_1d(), sampler.next_2d());
                let Some(ls) = rs.lights.sample_in_group(choices, g, s.p, uc, u) else {
                    continue;
                };
                let wi = s.frame.to_local(ls.wi);
                let f = bsdf.eval(wo, wi);
                let c = luminance((throughput * f * ls.weight).to_array());
                if !(c.is_finite() && c > 0.0) {
                    continue;
                }
                let (o, d, t) = shadow_ray(rs, &s, &ls);
                if !rs.accel.occluded(o, d, 0.0, t) {
                    // Drawn with probability draws / groups: each sum stays an estimate of
                    // the group's own.
                    let c = c as f64;
                    sums.first[g] += c * scale;
                    sums.second[g] += c * c * scale;
                    // The power heuristic as the path tracer weighs this sample (0 for Dirac
                    // lights' density: weight 1).
                    let light_pdf = ls.pdf * group_pmf[g];
                    let mis = if light_pdf > 0.0 {
                        power_heuristic(light_pdf, bsdf.pdf(wo, wi)) as f64
                    } else {
                        1.0
                    };
                    sums.weighted[g] += c * mis * scale;
                }
            }
        }
        let Some(bs) = bsdf.sample(wo, sampler.next_1d(), sampler.next_2d()) else {
            return;
        };
        throughput *= bs.weight;
        if !throughput.is_finite() || throughput == Vec3::ZERO {
            return;
        }
        dir = s.frame.to_world(bs.wi).normalize();
        origin = rs.offset(&s, dir);
    }
}

#[cfg(test)]
mod tests;
