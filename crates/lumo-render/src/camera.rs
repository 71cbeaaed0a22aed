//! The camera both ways: rays from the eye through the film (path tracing) and world
//! points projected back onto the film with the camera's importance (light tracing and
//! bidirectional connections). Camera rays may also come from a thin lens or an orthographic
//! projection and go through a pixel filter; the projections back onto the film are the
//! pinhole's only (the light tracer and BDPT refuse the others: [`PinholeCamera::unsupported_by_splats`]).

use glam::{Vec2, Vec3};
use lumo_scene::{Camera, Lens, PixelFilter};

/// A pinhole camera for one image size: precomputed basis, film extent and importance.
#[derive(Clone, Copy, Debug)]
// The fields are the crate's so that lane loops (the bidirectional splats) can repeat
// `project_point` and `direction_pdf` operation for operation.
pub struct PinholeCamera {
    /// Eye position.
    pub(crate) origin: Vec3,
    /// Unit view axis.
    pub(crate) forward: Vec3,
    /// Unit right axis.
    pub(crate) right: Vec3,
    /// Unit up axis.
    pub(crate) up: Vec3,
    /// Right and up scaled by the film's half-extents at distance 1.
    right_extent: Vec3,
    up_extent: Vec3,
    /// Half-extents of the film at distance 1.
    pub(crate) half: Vec2,
    /// Film size in pixels.
    pub(crate) size: Vec2,
    inv_size: Vec2,
    /// Pixels per unit film area at distance 1 ([`PinholeCamera::pixel_importance`]).
    pixel_importance: f32,
    /// Pinhole, thin lens or orthographic (its half-extents in world units).
    lens: Lens,
    /// The pixel reconstruction filter camera samples are placed with.
    filter: PixelFilter,
}

impl PinholeCamera {
    /// The camera for a `width`×`height` image.
    pub fn new(camera: &Camera, width: usize, height: usize) -> Self {
        let (right, up, forward) = camera.basis();
        let (hw, hh) = camera.half_extent(width, height);
        Self {
            origin: camera.origin,
            forward,
            right,
            up,
            right_extent: right * hw,
            up_extent: up * hh,
            half: Vec2::new(hw, hh),
            size: Vec2::new(width as f32, height as f32),
            inv_size: Vec2::new(1.0 / width as f32, 1.0 / height as f32),
            pixel_importance: (width * height) as f32 / (4.0 * hw * hh),
            lens: camera.lens,
            filter: camera.filter,
        }
    }

    /// The pixel reconstruction filter.
    pub fn filter(&self) -> &PixelFilter {
        &self.filter
    }

    /// The offset from the corner of pixel `(x, y)` (pixels) of a camera sample whose uniform
    /// point is `u`: placed by the pixel filter and kept on the film (`u` itself for the box
    /// filter, bit for bit).
    #[inline]
    pub fn filter_offset(&self, (x, y): (usize, usize), u: Vec2) -> Vec2 {
        if self.filter == PixelFilter::Box {
            return u;
        }
        let centre = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
        Vec2::splat(0.5)
            + crate::pixel_filter::filter_offset(&self.filter, u, -centre, self.size - centre)
    }

    /// Whether camera rays need a lens sample (a thin lens of non-zero aperture).
    #[inline]
    pub fn needs_lens_sample(&self) -> bool {
        matches!(self.lens, Lens::Thin { aperture_radius, .. } if aperture_radius > 0.0)
    }

    /// The camera ray (origin, unit direction) through image position `film` (pixels; x
    /// right, y down) and, for a thin lens, lens point `lens` in [0, 1)² (ignored otherwise).
    /// A pinhole's ray is `(origin(), direction(film))` exactly.
    #[inline]
    pub fn ray(&self, film: Vec2, lens: Vec2) -> (Vec3, Vec3) {
        match self.lens {
            Lens::Pinhole => (self.origin, self.direction(film)),
            Lens::Thin {
                aperture_radius,
                focus_distance,
            } => {
                let ndc = film * self.inv_size;
                let (sx, sy) = (2.0 * ndc.x - 1.0, 1.0 - 2.0 * ndc.y);
                // The point this film position sees sharply, on the plane in focus.
                let focus = self.origin
                    + (self.forward + self.right_extent * sx + self.up_extent * sy)
                        * focus_distance;
                let d = crate::geometry::square_to_disk(lens) * aperture_radius;
                let origin = self.origin + self.right * d.x + self.up * d.y;
                match (focus - origin).try_normalize() {
                    Some(dir) => (origin, dir),
                    None => (self.origin, self.direction(film)),
                }
            }
            Lens::Orthographic {
                half_width,
                half_height,
            } => {
                let ndc = film * self.inv_size;
                let (sx, sy) = (2.0 * ndc.x - 1.0, 1.0 - 2.0 * ndc.y);
                let origin =
                    self.origin + self.right * (sx * half_width) + self.up * (sy * half_height);
                (origin, self.forward)
            }
        }
    }

    /// What of this camera the integrators that project onto the film (light tracer, BDPT)
    /// cannot render: a thin lens, an orthographic projection or a filter other than the box.
    /// `None` when they can.
    pub fn unsupported_by_splats(&self) -> Option<String> {
        let lens = match self.lens {
            Lens::Pinhole => None,
            Lens::Thin { .. } if !self.needs_lens_sample() => None,
            Lens::Thin { .. } => Some("a thin-lens camera (depth of field)"),
            Lens::Orthographic { .. } => Some("an orthographic camera"),
        };
        let filter = match self.filter {
            PixelFilter::Box => None,
            PixelFilter::Tent { .. } => Some("the tent pixel filter"),
            PixelFilter::Gaussian { .. } => Some("the gaussian pixel filter"),
        };
        let what: Vec<&str> = lens.into_iter().chain(filter).collect();
        (!what.is_empty()).then(|| what.join(" and "))
    }

    /// Film size in pixels (width, height).
    pub fn film_size(&self) -> (f32, f32) {
        (self.size.x, self.size.y)
    }

    /// Eye position.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// Unit direction through image position `film` (pixels; x right, y down).
    #[inline]
    pub fn direction(&self, film: Vec2) -> Vec3 {
        let ndc = film * self.inv_size;
        let (sx, sy) = (2.0 * ndc.x - 1.0, 1.0 - 2.0 * ndc.y);
        (self.forward + self.right_extent * sx + self.up_extent * sy).normalize()
    }

    /// Image position (pixels) where world direction `dir` from the eye lands, if in front
    /// (it may lie outside the film).
    pub fn project(&self, dir: Vec3) -> Option<Vec2> {
        let z = dir.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = dir.dot(self.right_extent) / (z * self.right_extent.length_squared());
        let sy = dir.dot(self.up_extent) / (z * self.up_extent.length_squared());
        Some(Vec2::new(
            (sx + 1.0) * 0.5 / self.inv_size.x,
            (1.0 - sy) * 0.5 / self.inv_size.y,
        ))
    }

    /// Film position (pixels, x right, y down) of world point `p` and the cosine between the
    /// view axis and the direction to `p`, if `p` is in front and inside the film.
    pub fn project_point(&self, p: Vec3) -> Option<(Vec2, f32)> {
        let d = p - self.origin;
        let (sx, sy, z) = self.on_film(d)?;
        let film = Vec2::new((sx + 1.0) * 0.5, (1.0 - sy) * 0.5) * self.size;
        Some((film, z / d.length()))
    }

    /// Where offset `d` from the eye crosses the film at distance 1, in [-1, 1)² (x right,
    /// y up), and its depth along the view axis; `None` behind the eye or off the film.
    fn on_film(&self, d: Vec3) -> Option<(f32, f32, f32)> {
        let z = d.dot(self.forward);
        if z <= 0.0 {
            return None;
        }
        let sx = d.dot(self.right) / (z * self.half.x);
        let sy = d.dot(self.up) / (z * self.half.y);
        let inside = (-1.0..1.0).contains(&sx) && (-1.0..1.0).contains(&sy);
        inside.then_some((sx, sy, z))
    }

    /// Pixels per unit film area at distance 1. The importance a pixel-sized filter gives a
    /// direction at angle θ to the view axis is `pixel_importance / cos⁴θ` (the film at
    /// distance 1 seen under solid angle `cos³θ dA`), so a connection from a surface point at
    /// distance d contributes `G·We = |cos_surface| · pixel_importance / (d² cos³θ)`.
    pub fn pixel_importance(&self) -> f32 {
        self.pixel_importance
    }

    /// Solid-angle density with which [`PinholeCamera::direction`] at a uniformly random film
    /// position leaves the eye in unit direction `dir`: `1 / (A cos³θ)` with A the film's
    /// area at distance 1 and θ the angle to the view axis; 0 outside the film. (A pinhole's
    /// position is a delta: its density is 1.) Bidirectional methods weigh camera subpaths
    /// with it.
    pub fn direction_pdf(&self, dir: Vec3) -> f32 {
        let Some((_, _, cos)) = self.on_film(dir) else {
            return 0.0;
        };
        let area = 4.0 * self.half.x * self.half.y;
        1.0 / (area * cos * cos * cos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lumo_scene::FovAxis;

    fn camera() -> PinholeCamera {
        let c = Camera {
            origin: Vec3::new(0.3, 0.2, 4.0),
            target: Vec3::new(-0.5, 0.1, 0.0),
            up: Vec3::Y,
            fov: 50.0,
            fov_axis: FovAxis::X,
            lens: Default::default(),
            filter: Default::default(),
        };
        PinholeCamera::new(&c, 40, 30)
    }

    /// The direction density integrates to 1 over the sphere (Monte Carlo with uniform
    /// directions) and projection inverts ray generation.
    #[test]
    fn direction_density_integrates_to_one_and_projection_inverts_rays() {
        let cam = camera();
        let n = 400_000u32;
        let mut sum = 0.0f64;
        for i in 0..n {
            let mut s = crate::sampler::PixelSampler::new(0, 0, i, 4);
            let d = crate::geometry::square_to_uniform_sphere(s.next_2d());
            sum += cam.direction_pdf(d) as f64 / crate::geometry::UNIFORM_SPHERE_PDF as f64;
        }
        let integral = sum / n as f64;
        assert!((integral - 1.0).abs() < 0.02, "∫ pdf dω = {integral}");
        for film in [
            Vec2::new(0.5, 0.5),
            Vec2::new(12.3, 20.7),
            Vec2::new(39.5, 1.0),
        ] {
            let dir = cam.direction(film);
            let back = cam.project(dir).expect("in front");
            assert!((back - film).length() < 1e-3, "{film} -> {back}");
            let (point, _) = cam
                .project_point(cam.origin() + dir * 3.0)
                .expect("on the film");
            assert!((point - film).length() < 1e-3, "{film} -> {point}");
        }
    }

    /// A thin lens's rays for one film point all meet on the plane in focus, at the point the
    /// pinhole's ray through that film point reaches; they leave a disk of the aperture's
    /// radius. A zero aperture is the pinhole exactly.
    #[test]
    fn thin_lens_rays_meet_on_the_focus_plane() {
        let mut c = Camera {
            origin: Vec3::new(0.3, 0.2, 4.0),
            target: Vec3::new(-0.5, 0.1, 0.0),
            up: Vec3::Y,
            fov: 50.0,
            fov_axis: FovAxis::X,
            lens: Lens::Thin {
                aperture_radius: 0.2,
                focus_distance: 3.0,
            },
            filter: PixelFilter::Box,
        };
        let cam = PinholeCamera::new(&c, 40, 30);
        let film = Vec2::new(7.25, 21.5);
        let pin = cam.direction(film);
        let sharp = cam.origin() + pin * (3.0 / pin.dot(cam.forward));
        let mut widest = 0.0f32;
        for i in 0..64 {
            let lens = Vec2::new((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.06);
            let (o, d) = cam.ray(film, lens);
            assert!((d.length() - 1.0).abs() < 1e-5);
            assert!(
                (o - cam.origin()).dot(cam.forward).abs() < 1e-5,
                "on the lens plane"
            );
            widest = widest.max((o - cam.origin()).length());
            let t = (sharp - o).dot(cam.forward) / d.dot(cam.forward);
            assert!((o + d * t - sharp).length() < 1e-4, "{}", o + d * t);
        }
        assert!(widest > 0.15 && widest <= 0.2 + 1e-5, "{widest}");
        c.lens = Lens::Thin {
            aperture_radius: 0.0,
            focus_distance: 3.0,
        };
        let cam = PinholeCamera::new(&c, 40, 30);
        assert!(!cam.needs_lens_sample());
        assert!(cam.unsupported_by_splats().is_none());
    }

    /// Orthographic rays are parallel to the view axis and their origins span the view's
    /// half extents from the image's corners to its centre.
    #[test]
    fn orthographic_rays_are_parallel() {
        let c = Camera {
            origin: Vec3::new(0.0, 2.0, 0.0),
            target: Vec3::ZERO,
            up: Vec3::Z,
            fov: 90.0,
            fov_axis: FovAxis::X,
            lens: Lens::Orthographic {
                half_width: 2.0,
                half_height: 1.0,
            },
            filter: PixelFilter::Box,
        };
        let cam = PinholeCamera::new(&c, 40, 20);
        let (o0, d0) = cam.ray(Vec2::ZERO, Vec2::ZERO);
        let (o1, d1) = cam.ray(Vec2::new(40.0, 20.0), Vec2::ZERO);
        let (oc, _) = cam.ray(Vec2::new(20.0, 10.0), Vec2::ZERO);
        assert_eq!(d0, d1);
        assert!((d0 - Vec3::NEG_Y).length() < 1e-6, "{d0}");
        assert!((oc - c.origin).length() < 1e-5, "{oc}");
        let (right, up, _) = c.basis();
        assert!((o0 - (c.origin - right * 2.0 + up)).length() < 1e-5, "{o0}");
        assert!((o1 - (c.origin + right * 2.0 - up)).length() < 1e-5, "{o1}");
        assert!(cam.unsupported_by_splats().is_some());
    }
}
