//! What the direct-light split (`crate::direct_split`) asks of the lights: the Dirac lights
//! one by one, the constant-radiance triangles whose unshadowed irradiance has a closed form,
//! and a sample among the lights that are not Dirac deltas.

use glam::{Vec2, Vec3};

use super::{LightKind, LightSample, Lights, NO_TEXTURE};

impl Lights {
    /// Whether any light is a Dirac light (point, spot, directional).
    pub(crate) fn has_delta(&self) -> bool {
        self.lights[self.first_punctual..]
            .iter()
            .any(|l| l.is_delta())
    }

    /// Every point, spot and directional light as a sample from `p` (probability 1: `weight`
    /// is the intensity over the squared distance, or the irradiance), skipping spots whose
    /// cone does not reach `p`.
    pub(crate) fn delta_samples(&self, p: Vec3) -> impl Iterator<Item = LightSample> + '_ {
        // Past the area lights only: a mesh light's thousands of triangles are not walked per
        // pixel.
        let punctual = self.lights.iter().enumerate().skip(self.first_punctual);
        punctual.filter_map(move |(i, l)| {
            if l.is_delta() {
                self.sample_chosen(i, 1.0, l, p, Vec2::ZERO)
            } else {
                None
            }
        })
    }

    /// The corners and radiance of every emissive triangle whose radiance is one constant
    /// (no texture).
    pub(crate) fn constant_triangles(&self) -> impl Iterator<Item = ([Vec3; 3], Vec3)> + '_ {
        self.lights.iter().filter_map(|l| match l {
            LightKind::Triangle(t) if t.texture == NO_TEXTURE && t.area > 0.0 => {
                Some(([t.p0, t.p0 + t.e1, t.p0 + t.e2], t.radiance))
            }
            _ => None,
        })
    }

    /// Whether every light that is not a Dirac delta is a constant-radiance triangle (one of
    /// [`Lights::constant_triangles`]), so their unshadowed light has a closed form.
    pub(crate) fn only_constant_triangles(&self) -> bool {
        self.lights.iter().all(|l| match l {
            LightKind::Triangle(t) => t.texture == NO_TEXTURE,
            l => l.is_delta(),
        })
    }

    /// A point on a light that is not a Dirac delta (an emissive triangle or shape, or the
    /// environment), chosen in proportion to power among those only.
    pub(crate) fn sample_non_delta(&self, p: Vec3, u_choice: f32, u: Vec2) -> Option<LightSample> {
        let choice = self.area_choice.as_ref()?;
        let (index, _) = choice.sample(u_choice);
        let pick = choice.pmf(index);
        if pick <= 0.0 {
            return None;
        }
        self.sample_chosen(index, pick, &self.lights[index], p, u)
    }
}
