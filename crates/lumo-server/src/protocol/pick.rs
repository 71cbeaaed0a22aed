//! PICK (0x05, both ways): a viewer asks what is under an image position; the server casts the
//! camera ray through it and answers that viewer with what it hit (an object or a light) and
//! the values an EDIT of it starts from.

use glam::Vec3;

use super::enums::PickTarget;
use super::error::{ErrorCode, ProtocolError};
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};
use super::{kind, truncate_utf8, MAX_NAME};

const REQUEST: Field = Field::one(
    "request",
    4,
    FieldType::U32,
    "the viewer's number for the pick, echoed in the answer",
);
const UV: Field = Field::fixed(
    "uv",
    8,
    FieldType::F32,
    2,
    "image position in [0,1]², u left to right, v top to bottom",
);
const TARGET: Field = Field::one(
    "target",
    16,
    FieldType::Enum(&PickTarget::WIRE),
    "what was hit (server → viewer; 0 from a viewer)",
);
const HAS_COLOR: Field = Field::one(
    "hasColor",
    17,
    FieldType::Bool,
    "the object's material has a base colour EDIT can change",
);
const RESERVED: Field = Field::fixed("reserved", 18, FieldType::Reserved, 2, "reserved, 0");
const INDEX: Field = Field::one(
    "index",
    20,
    FieldType::U32,
    "object: instance index; light: light index",
);
const MESH: Field = Field::one("mesh", 24, FieldType::U32, "object: its mesh index");
const MATERIAL: Field = Field::one("material", 28, FieldType::U32, "object: its material index");
const POSITION: Field = Field::fixed(
    "position",
    32,
    FieldType::F32,
    3,
    "object: the instance's translation; light: its position (what a move sets)",
);
const POINT: Field = Field::fixed(
    "point",
    44,
    FieldType::F32,
    3,
    "the world point under the pixel (a light: its position)",
);
const COLOR: Field = Field::fixed(
    "color",
    56,
    FieldType::F32,
    3,
    "object: base colour, linear RGB (0 without one)",
);
const EMISSION: Field = Field::fixed(
    "emission",
    68,
    FieldType::F32,
    3,
    "object: its material's emitted radiance; light: its intensity",
);
const NAME_LENGTH: Field = Field::one(
    "nameLength",
    80,
    FieldType::U16,
    "name length in bytes (≤ 200)",
);
const NAME: Field = Field::tail(
    "name",
    82,
    FieldType::Utf8,
    1,
    &["nameLength"],
    "the mesh and material names, or the light's kind, UTF-8",
);

/// What a pick found, as the server answers it.
#[derive(Clone, Debug, PartialEq)]
pub struct PickHit {
    /// Object, light or nothing.
    pub target: PickTarget,
    /// The object's material has a base colour (EDIT `baseColor` applies).
    pub has_color: bool,
    /// Instance index (object) or light index (light).
    pub index: u32,
    /// The object's mesh (0 otherwise).
    pub mesh: u32,
    /// The object's material (0 otherwise).
    pub material: u32,
    /// The instance's translation or the light's position.
    pub position: Vec3,
    /// The world point under the pixel.
    pub point: Vec3,
    /// Base colour (object).
    pub color: Vec3,
    /// Emitted radiance (object) or intensity (light).
    pub emission: Vec3,
    /// Names for people (cut to [`MAX_NAME`] bytes when written).
    pub name: String,
}

impl PickHit {
    /// Nothing under the pixel.
    pub fn nothing() -> Self {
        Self {
            target: PickTarget::Nothing,
            has_color: false,
            index: 0,
            mesh: 0,
            material: 0,
            position: Vec3::ZERO,
            point: Vec3::ZERO,
            color: Vec3::ZERO,
            emission: Vec3::ZERO,
            name: String::new(),
        }
    }
}

/// PICK: the viewer's request (`hit` = nothing) or the server's answer to it.
#[derive(Clone, Debug, PartialEq)]
pub struct Pick {
    /// The viewer's number for the request.
    pub request: u32,
    /// Image position in [0,1]².
    pub uv: [f32; 2],
    /// What is there (a request: [`PickHit::nothing`]).
    pub hit: PickHit,
}

impl Pick {
    /// Field table of PICK.
    pub const LAYOUT: Layout = Layout::message(
        "PICK",
        kind::PICK,
        Direction::Both,
        &[
            REQUEST,
            UV,
            TARGET,
            HAS_COLOR,
            RESERVED,
            INDEX,
            MESH,
            MATERIAL,
            POSITION,
            POINT,
            COLOR,
            EMISSION,
            NAME_LENGTH,
            NAME,
        ],
    );

    /// Encodes it.
    pub fn write(&self) -> Vec<u8> {
        let name = truncate_utf8(&self.hit.name, MAX_NAME);
        let mut w = Writer::new(&Self::LAYOUT, name.len());
        let h = &self.hit;
        w.put(&REQUEST, self.request);
        w.put_at(&UV, 0, self.uv[0]);
        w.put_at(&UV, 1, self.uv[1]);
        w.put(&TARGET, h.target.code());
        w.put(&HAS_COLOR, h.has_color as u8);
        w.put(&INDEX, h.index);
        w.put(&MESH, h.mesh);
        w.put(&MATERIAL, h.material);
        for (f, v) in [
            (&POSITION, h.position),
            (&POINT, h.point),
            (&COLOR, h.color),
            (&EMISSION, h.emission),
        ] {
            for (i, x) in v.to_array().into_iter().enumerate() {
                w.put_at(f, i, x);
            }
        }
        w.put(&NAME_LENGTH, name.len() as u16);
        w.extend(name.as_bytes());
        w.finish()
    }

    /// Decodes the fields. The image position must be finite and in [0,1]² (what a viewer
    /// sends is checked here; the rest is the server's answer, read by tools and tests).
    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let uv: [f32; 2] = [r.get_at(&UV, 0)?, r.get_at(&UV, 1)?];
        if !uv.iter().all(|c| (0.0..=1.0).contains(c)) {
            return Err(ProtocolError::new(
                ErrorCode::InvalidValue,
                format!("pick position {uv:?} is not in [0,1]²"),
            ));
        }
        let t = r.get::<u8>(&TARGET)?;
        let target = PickTarget::from_code(t).ok_or_else(|| {
            ProtocolError::new(ErrorCode::InvalidValue, format!("pick target {t}"))
        })?;
        let v = |f: &Field| -> Result<Vec3, ProtocolError> {
            Ok(Vec3::new(r.get_at(f, 0)?, r.get_at(f, 1)?, r.get_at(f, 2)?))
        };
        let len = r.get::<u16>(&NAME_LENGTH)? as usize;
        let name = std::str::from_utf8(r.tail(len, "name length")?)
            .map_err(|_| ProtocolError::new(ErrorCode::InvalidValue, "pick name is not UTF-8"))?
            .to_owned();
        Ok(Self {
            request: r.get(&REQUEST)?,
            uv,
            hit: PickHit {
                target,
                has_color: r.get::<u8>(&HAS_COLOR)? != 0,
                index: r.get(&INDEX)?,
                mesh: r.get(&MESH)?,
                material: r.get(&MATERIAL)?,
                position: v(&POSITION)?,
                point: v(&POINT)?,
                color: v(&COLOR)?,
                emission: v(&EMISSION)?,
                name,
            },
        })
    }
}
