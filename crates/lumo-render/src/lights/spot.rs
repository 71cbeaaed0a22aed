//! Spot lights: a point light limited to a cone, full inside the beam and falling off to the
//! cutoff (linear in angle as Mitsuba 3's `spot`, or glTF's squared ramp in cosine).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use lumo_image::luminance;
use lumo_scene::SpotFalloff;

use super::point::windowed;
use super::source::LightSource;
use super::{EmissionPdf, EmissionSample, LightSample, Lights};
use crate::geometry::Basis;

/// A spot light's cone: full intensity inside the beam, falling off to zero at the cutoff,
/// linearly in angle as Mitsuba 3's `spot` defines it (its `falloff_curve`), or as glTF's
/// squared ramp in cosine.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotCone {
    cos_beam: f32,
    cos_cutoff: f32,
    cutoff: f32,
    inv_transition: f32,
    curve: SpotFalloff,
}

impl SpotCone {
    /// The cone of a spot with the given beam width and cutoff half-angles in degrees (a beam
    /// wider than the cutoff is clamped to it) and falloff curve between them.
    pub fn new(beam_width_deg: f32, cutoff_deg: f32, curve: SpotFalloff) -> Self {
        let cutoff = cutoff_deg.to_radians();
        let beam = beam_width_deg.min(cutoff_deg).to_radians();
        let (cos_beam, cos_cutoff) = (beam.cos(), cutoff.cos());
        // A hard-edged spot (beam = cutoff) never reaches the transition branch.
        let inv_transition = match curve {
            _ if cutoff <= beam => 0.0,
            SpotFalloff::LinearAngle => 1.0 / (cutoff - beam),
            SpotFalloff::SquaredCosine => 1.0 / (cos_beam - cos_cutoff),
        };
        Self {
            cos_beam,
            cos_cutoff,
            cutoff,
            inv_transition,
            curve,
        }
    }

    /// Cosine of the cutoff angle: nothing is emitted outside it.
    pub fn cos_cutoff(&self) -> f32 {
        self.cos_cutoff
    }

    /// The factor in [0, 1] applied to the intensity at `cos` from the axis.
    #[inline]
    pub fn falloff(&self, cos: f32) -> f32 {
        if cos <= self.cos_cutoff {
            0.0
        } else if cos >= self.cos_beam {
            1.0
        } else {
            match self.curve {
                SpotFalloff::LinearAngle => ((self.cutoff - cos.clamp(-1.0, 1.0).acos())
                    * self.inv_transition)
                    .clamp(0.0, 1.0),
                SpotFalloff::SquaredCosine => {
                    let r = ((cos - self.cos_cutoff) * self.inv_transition).clamp(0.0, 1.0);
                    r * r
                }
            }
        }
    }

    /// ∫ falloff dω over the sphere: the emitted power over the intensity. With θ_b the beam
    /// and θ_c the cutoff angle: linear in angle 2π (1 − (sin θ_c − sin θ_b) / (θ_c − θ_b));
    /// squared in cosine 2π (1 − cos θ_b) + 2π (cos θ_b − cos θ_c) / 3; 2π (1 − cos θ_b) for a
    /// hard edge.
    pub fn solid_angle(&self) -> f32 {
        let beam = self.cos_beam.clamp(-1.0, 1.0).acos();
        if self.inv_transition == 0.0 {
            return 2.0 * PI * (1.0 - self.cos_beam);
        }
        match self.curve {
            SpotFalloff::LinearAngle => {
                2.0 * PI * (1.0 - (self.cutoff.sin() - beam.sin()) * self.inv_transition)
            }
            SpotFalloff::SquaredCosine => {
                2.0 * PI * (1.0 - self.cos_beam)
                    + 2.0 * PI * (self.cos_beam - self.cos_cutoff) / 3.0
            }
        }
    }
}

/// A spot light.
pub(crate) struct SpotLight {
    /// Where it is.
    pub(super) position: Vec3,
    /// Unit direction of the cone's axis.
    pub(super) axis: Vec3,
    /// Radiant intensity on the axis.
    pub(super) intensity: Vec3,
    /// The cone.
    pub(super) cone: SpotCone,
    /// Distance at which it stops (glTF's `range`), `None` for none.
    pub(super) range: Option<f32>,
}

impl LightSource for SpotLight {
    fn power(&self, _disk: f32) -> f32 {
        // Without the range's window, as the point light's (`point.rs`).
        self.cone.solid_angle() * luminance(self.intensity.into())
    }

    fn is_delta(&self) -> bool {
        true
    }

    fn emits_particles(&self) -> bool {
        true
    }

    #[inline(always)]
    fn sample_from(
        &self,
        _lights: &Lights,
        light: u32,
        pick: f32,
        p: Vec3,
        _u: Vec2,
    ) -> Option<LightSample> {
        let d = self.position - p;
        let dist2 = d.length_squared();
        let distance = dist2.sqrt();
        let wi = d / distance;
        let falloff = self.cone.falloff(self.axis.dot(-wi));
        if falloff <= 0.0 {
            return None;
        }
        let intensity = windowed(self.intensity, self.range, distance)?;
        Some(LightSample {
            light,
            normal: Vec3::ZERO,
            wi,
            distance,
            point: self.position,
            weight: intensity * falloff / (dist2 * pick),
            pdf: 0.0,
        })
    }

    fn pdf_from(&self, _lights: &Lights, _pick: f32, _from: Vec3, _point: Vec3) -> f32 {
        0.0
    }

    fn emit(
        &self,
        _lights: &Lights,
        light: u32,
        pick: f32,
        _u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionSample> {
        // Uniform in the cutoff cone, weighted by the falloff.
        let cone = &self.cone;
        let cos_outer = cone.cos_cutoff();
        let cos = 1.0 - u_dir.x * (1.0 - cos_outer);
        let sin = (1.0 - cos * cos).max(0.0).sqrt();
        let phi = 2.0 * PI * u_dir.y;
        let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
        let falloff = cone.falloff(cos);
        let pdf_dir = 1.0 / (2.0 * PI * (1.0 - cos_outer));
        Some(EmissionSample {
            light,
            p: self.position,
            normal: None,
            radiance: Vec3::ZERO,
            dir: Basis::new(self.axis).to_world(local).normalize(),
            weight: self.intensity * falloff / (pick * pdf_dir),
            pdf: EmissionPdf {
                area: pick,
                solid_angle: pdf_dir,
                delta_position: true,
                delta_direction: false,
            },
        })
    }

    fn emission_pdf(
        &self,
        _lights: &Lights,
        pick: f32,
        _n: Vec3,
        dir: Vec3,
    ) -> Option<EmissionPdf> {
        let cos_outer = self.cone.cos_cutoff();
        let inside = self.axis.dot(dir) >= cos_outer;
        let pdf = if inside {
            1.0 / (2.0 * PI * (1.0 - cos_outer))
        } else {
            0.0
        };
        Some(EmissionPdf {
            area: pick,
            solid_angle: pdf,
            delta_position: true,
            delta_direction: false,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The power a spot reports is its falloff integrated over the sphere (midpoint rule in
    /// cos θ, where dω = 2π d(cos θ)), for both curves and a hard edge; and glTF's curve is
    /// its spec's formula.
    #[test]
    fn solid_angle_is_the_integral_of_the_falloff() {
        for curve in [SpotFalloff::LinearAngle, SpotFalloff::SquaredCosine] {
            for (beam, cutoff) in [(20.0, 35.0), (0.0, 60.0), (30.0, 30.0), (10.0, 89.0)] {
                let cone = SpotCone::new(beam, cutoff, curve);
                let n = 200_000;
                let sum: f64 = (0..n)
                    .map(|i| {
                        let cos = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                        cone.falloff(cos as f32) as f64
                    })
                    .sum();
                let numeric = 2.0 * std::f64::consts::PI * sum * 2.0 / n as f64;
                let closed = cone.solid_angle() as f64;
                assert!(
                    (numeric - closed).abs() < 1e-4 * closed.max(1e-3),
                    "{curve:?} {beam}/{cutoff}: {numeric} vs {closed}"
                );
            }
        }
        let gltf = SpotCone::new(20.0, 40.0, SpotFalloff::SquaredCosine);
        let (ci, co) = (20f32.to_radians().cos(), 40f32.to_radians().cos());
        let c = 30f32.to_radians().cos();
        let want = ((c - co) / (ci - co)).powi(2);
        assert!((gltf.falloff(c) - want).abs() < 1e-6);
        // The two curves differ inside the transition: glTF's is darker near the cutoff.
        let mitsuba = SpotCone::new(20.0, 40.0, SpotFalloff::LinearAngle);
        assert!(gltf.falloff(c) < mitsuba.falloff(c) - 0.1);
    }
}
