//! Perfect specular reflection.

use glam::Vec3;

/// A perfect mirror with a constant reflectance (lumo's built-in scenes; Mitsuba's smooth
/// `conductor` is [`super::Conductor`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mirror {
    /// Reflectance.
    pub reflectance: Vec3,
}
