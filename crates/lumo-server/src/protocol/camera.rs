//! CAMERA (0x02, both ways): the pinhole camera, its checks, and the camera fields that HELLO
//! embeds too.

use glam::Vec3;

use super::error::{ErrorCode, ProtocolError};
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};
use super::{kind, MAX_CAMERA_COORD};

/// A pinhole camera as sent over the wire.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WireCamera {
    /// Eye.
    pub origin: Vec3,
    /// Point looked at.
    pub target: Vec3,
    /// Up hint.
    pub up: Vec3,
    /// Field of view in degrees along the image's shorter side.
    pub fov: f32,
}

impl WireCamera {
    /// Checks that the camera defines a usable view.
    pub fn validate(&self) -> Result<(), ProtocolError> {
        let finite = [self.origin, self.target, self.up]
            .iter()
            .all(|v| v.is_finite())
            && self.fov.is_finite();
        if !finite {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                "camera has non-finite numbers",
            ));
        }
        if !(1.0..=170.0).contains(&self.fov) {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                format!("field of view {} outside 1..=170 degrees", self.fov),
            ));
        }
        let invalid = |m: String| Err(ProtocolError::new(ErrorCode::InvalidValue, m));
        for (name, v) in [
            ("origin", self.origin),
            ("target", self.target),
            ("up", self.up),
        ] {
            let m = v.abs().max_element();
            if m > MAX_CAMERA_COORD {
                return invalid(format!(
                    "camera {name} coordinate {m:e} is beyond ±{MAX_CAMERA_COORD:e}, where the \
                     renderer's single-precision distances overflow"
                ));
            }
        }
        // Direction first, then normalisable: within the bound above the difference and its
        // squared length stay finite, so a zero or denormal-tiny difference is what fails here.
        let Some(forward) = (self.target - self.origin).try_normalize() else {
            return invalid("camera target coincides with its origin (no view direction)".into());
        };
        // The renderer builds right = normalize(forward × up): that must be normalisable, and
        // up must not be (nearly) parallel to the view.
        let right = forward.cross(self.up);
        if right.try_normalize().is_none() || right.length() < 1e-4 * self.up.length() {
            return invalid(
                "camera up vector is zero, too short, or parallel to the view direction".into(),
            );
        }
        Ok(())
    }
}

/// The camera's fields (epoch first) where a message holds them: CAMERA at 4, HELLO at 22.
/// One definition, so both messages lay the camera out alike.
#[derive(Clone, Copy, Debug)]
pub(super) struct CameraFields {
    pub(super) epoch: Field,
    pub(super) origin: Field,
    pub(super) target: Field,
    pub(super) up: Field,
    pub(super) fov: Field,
}

impl CameraFields {
    /// The fields starting at byte `at`; `epoch` says what the epoch means there.
    pub(super) const fn at(at: usize, epoch: &'static str) -> Self {
        Self {
            epoch: Field::one("epoch", at, FieldType::U32, epoch),
            origin: Field::fixed("origin", at + 4, FieldType::F32, 3, "eye position"),
            target: Field::fixed("target", at + 16, FieldType::F32, 3, "point looked at"),
            up: Field::fixed("up", at + 28, FieldType::F32, 3, "up hint"),
            fov: Field::one(
                "fov",
                at + 40,
                FieldType::F32,
                "field of view in degrees along the image's shorter side, 1..=170",
            ),
        }
    }

    /// The fields in offset order.
    pub(super) const fn list(self) -> [Field; 5] {
        [self.epoch, self.origin, self.target, self.up, self.fov]
    }

    pub(super) fn write(&self, w: &mut Writer, epoch: u32, c: &WireCamera) {
        w.put(&self.epoch, epoch);
        for (field, v) in [
            (&self.origin, c.origin),
            (&self.target, c.target),
            (&self.up, c.up),
        ] {
            for (i, x) in v.to_array().into_iter().enumerate() {
                w.put_at(field, i, x);
            }
        }
        w.put(&self.fov, c.fov);
    }

    pub(super) fn read(&self, r: &Reader) -> Result<(u32, WireCamera), ProtocolError> {
        let v = |f: &Field| -> Result<Vec3, ProtocolError> {
            Ok(Vec3::new(r.get_at(f, 0)?, r.get_at(f, 1)?, r.get_at(f, 2)?))
        };
        let camera = WireCamera {
            origin: v(&self.origin)?,
            target: v(&self.target)?,
            up: v(&self.up)?,
            fov: r.get(&self.fov)?,
        };
        Ok((r.get(&self.epoch)?, camera))
    }
}

const FIELDS: CameraFields = CameraFields::at(
    4,
    "epoch (server → viewer: the render using this camera; viewer → server: ignored)",
);
const LIST: [Field; 5] = FIELDS.list();

/// CAMERA: a viewer asks for a camera (epoch ignored); the server confirms it to every viewer
/// with the epoch of the render that uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraUpdate {
    /// Epoch of the render using the camera (0 from viewers).
    pub epoch: u32,
    /// The camera.
    pub camera: WireCamera,
}

impl CameraUpdate {
    /// Field table of CAMERA.
    pub const LAYOUT: Layout = Layout::message("CAMERA", kind::CAMERA, Direction::Both, &LIST);

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, 0);
        FIELDS.write(&mut w, self.epoch, &self.camera);
        w.finish()
    }

    /// Decodes the fields (not [`WireCamera::validate`]: the server checks viewers' cameras).
    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let (epoch, camera) = FIELDS.read(r)?;
        Ok(Self { epoch, camera })
    }
}
