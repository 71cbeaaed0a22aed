//! WELCOME (0x21, hub → worker): the answer to an accepted WORKER_HELLO: the scene (a built-in
//! name or a path every worker must be able to read, with the `-D` defines) and the render
//! settings, so the worker renders what the hub's own render worker does.

use lumo_render::{PathSettings, PpmSettings};

use super::super::error::{ErrorCode, ProtocolError};
use super::super::layout::{wire_enum, Direction, Field, FieldType, Layout, Reader, Writer};
use super::super::read_message;
use super::kind;

/// Most bytes of the scene text (the name or path and its defines).
pub const MAX_SCENE_TEXT: usize = 16 << 10;
/// Longest image side a worker renders (the camera stream's sample order addresses 65536).
const MAX_SIDE: u32 = 65536;

wire_enum! {
    /// How the scene is named.
    pub enum SceneKind: u8, "sceneKind" {
        /// A built-in scene's name.
        Builtin = 0, "builtin", "built-in scene";
        /// An absolute path to a scene file that every worker's machine can read.
        File = 1, "file", "scene file";
    }
}

/// The scene a hub renders, as workers load it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneSource {
    /// Built-in or file.
    pub kind: SceneKind,
    /// The built-in's name or the file's absolute path.
    pub spec: String,
    /// Mitsuba `$name` parameters (`-D NAME=VALUE`), in the order given.
    pub defines: Vec<(String, String)>,
}

const WORKER: Field = Field::one(
    "worker",
    4,
    FieldType::U32,
    "the worker's number at this hub (its log lines name it)",
);
const SEED: Field = Field::one(
    "seed",
    8,
    FieldType::U32,
    "seed of this worker's samples (its own, so its samples add new information)",
);
const WIDTH: Field = Field::one("width", 12, FieldType::U32, "image width");
const HEIGHT: Field = Field::one("height", 16, FieldType::U32, "image height");
const MAX_DEPTH: Field = Field::one("maxDepth", 20, FieldType::U32, "longest path depth");
const RR_DEPTH: Field = Field::one("rrDepth", 24, FieldType::U32, "Russian-roulette depth");
const NEE: Field = Field::one("nee", 28, FieldType::Bool, "next-event estimation");
const BSDF_EMISSION: Field = Field::one(
    "bsdfEmission",
    29,
    FieldType::Bool,
    "BSDF-sampled hits of emitters count",
);
const SPECTRAL: Field = Field::one("spectral", 30, FieldType::Bool, "spectral transport");
const ANIMATE: Field = Field::one(
    "animate",
    31,
    FieldType::Bool,
    "pose the scene's glTF animation at EPOCH's time",
);
const PHOTONS_PER_PASS: Field = Field::one(
    "photonsPerPass",
    32,
    FieldType::U64,
    "photon mapping: photon paths per pass (0: one per pixel)",
);
const MAX_PHOTONS: Field = Field::one(
    "maxPhotons",
    40,
    FieldType::U64,
    "photon mapping: most photons in a map",
);
const PHOTON_RADIUS: Field = Field::one(
    "photonRadius",
    48,
    FieldType::F32,
    "photon mapping: first radius (fraction of the scene diagonal)",
);
const PHOTON_ALPHA: Field = Field::one("photonAlpha", 52, FieldType::F32, "photon mapping: α");
const SCENE_KIND: Field = Field::one(
    "sceneKind",
    56,
    FieldType::Enum(&SceneKind::WIRE),
    "how the scene is named",
);
const RESERVED: Field = Field::fixed("reserved", 57, FieldType::Reserved, 1, "reserved, 0");
const SCENE_LENGTH: Field = Field::one(
    "sceneLength",
    58,
    FieldType::U16,
    "scene text length in bytes (≤ 16384)",
);
const SCENE: Field = Field::tail(
    "scene",
    60,
    FieldType::Utf8,
    1,
    &["sceneLength"],
    "the built-in's name or the file's absolute path, then per define a NUL byte and NAME=VALUE",
);

/// The hub's answer to an accepted worker.
#[derive(Clone, Debug)]
pub struct Welcome {
    /// The worker's number at this hub.
    pub worker: u32,
    /// Seed of this worker's samples.
    pub seed: u32,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Path settings of both tracers.
    pub path: PathSettings,
    /// Pose the scene's animation at each epoch's time.
    pub animate: bool,
    /// Photon-mapping settings.
    pub ppm: PpmSettings,
    /// The scene.
    pub scene: SceneSource,
}

impl Welcome {
    /// Field table of WELCOME.
    pub const LAYOUT: Layout = Layout::message(
        "WELCOME",
        kind::WELCOME,
        Direction::ToWorker,
        &[
            WORKER,
            SEED,
            WIDTH,
            HEIGHT,
            MAX_DEPTH,
            RR_DEPTH,
            NEE,
            BSDF_EMISSION,
            SPECTRAL,
            ANIMATE,
            PHOTONS_PER_PASS,
            MAX_PHOTONS,
            PHOTON_RADIUS,
            PHOTON_ALPHA,
            SCENE_KIND,
            RESERVED,
            SCENE_LENGTH,
            SCENE,
        ],
    );

    /// The scene text: the name or path, then `\0NAME=VALUE` per define.
    fn scene_text(&self) -> String {
        let mut s = self.scene.spec.clone();
        for (k, v) in &self.scene.defines {
            s.push('\0');
            s.push_str(k);
            s.push('=');
            s.push_str(v);
        }
        s
    }

    /// Encodes it; a scene text over [`MAX_SCENE_TEXT`] bytes is refused (a cut path would
    /// name another file).
    pub fn write(&self) -> Result<Vec<u8>, ProtocolError> {
        let text = self.scene_text();
        if text.len() > MAX_SCENE_TEXT {
            return Err(ProtocolError::new(
                ErrorCode::TooLarge,
                format!(
                    "scene path and defines take {} bytes (at most {MAX_SCENE_TEXT})",
                    text.len()
                ),
            ));
        }
        let mut w = Writer::new(&Self::LAYOUT, text.len());
        w.put(&WORKER, self.worker);
        w.put(&SEED, self.seed);
        w.put(&WIDTH, self.width);
        w.put(&HEIGHT, self.height);
        w.put(&MAX_DEPTH, self.path.max_depth);
        w.put(&RR_DEPTH, self.path.rr_depth);
        w.put(&NEE, self.path.nee as u8);
        w.put(&BSDF_EMISSION, self.path.bsdf_emission as u8);
        w.put(&SPECTRAL, self.path.spectral as u8);
        w.put(&ANIMATE, self.animate as u8);
        w.put(&PHOTONS_PER_PASS, self.ppm.photons_per_pass);
        w.put(&MAX_PHOTONS, self.ppm.max_photons as u64);
        w.put(&PHOTON_RADIUS, self.ppm.radius);
        w.put(&PHOTON_ALPHA, self.ppm.alpha);
        w.put(&SCENE_KIND, self.scene.kind.code());
        w.put(&SCENE_LENGTH, text.len() as u16);
        w.extend(text.as_bytes());
        Ok(w.finish())
    }

    /// Decodes a whole message.
    pub fn read(msg: &[u8]) -> Result<Self, ProtocolError> {
        read_message(msg, &Self::LAYOUT, Self::decode)
    }

    fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        let bad = |m: String| ProtocolError::new(ErrorCode::InvalidValue, m);
        let k = r.get::<u8>(&SCENE_KIND)?;
        let kind = SceneKind::from_code(k).ok_or_else(|| bad(format!("scene kind {k}")))?;
        let len = r.get::<u16>(&SCENE_LENGTH)? as usize;
        let text = std::str::from_utf8(r.tail(len, "scene length")?)
            .map_err(|_| ProtocolError::new(ErrorCode::Malformed, "scene text is not UTF-8"))?;
        let mut parts = text.split('\0');
        let spec = parts.next().unwrap_or_default().to_string();
        let defines = parts
            .map(|d| {
                d.split_once('=')
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .ok_or_else(|| bad(format!("define {d:?} is not NAME=VALUE")))
            })
            .collect::<Result<_, _>>()?;
        let max_photons = r.get::<u64>(&MAX_PHOTONS)?;
        let (width, height): (u32, u32) = (r.get(&WIDTH)?, r.get(&HEIGHT)?);
        // The sample order's bound (and far above the viewer's 4096²): a worker renders no
        // empty or unaddressable image.
        if !(1..=MAX_SIDE).contains(&width) || !(1..=MAX_SIDE).contains(&height) {
            return Err(bad(format!(
                "image size {width}x{height} (1..={MAX_SIDE} a side)"
            )));
        }
        Ok(Self {
            worker: r.get(&WORKER)?,
            seed: r.get(&SEED)?,
            width,
            height,
            path: PathSettings {
                max_depth: r.get(&MAX_DEPTH)?,
                rr_depth: r.get(&RR_DEPTH)?,
                nee: r.get::<u8>(&NEE)? != 0,
                bsdf_emission: r.get::<u8>(&BSDF_EMISSION)? != 0,
                spectral: r.get::<u8>(&SPECTRAL)? != 0,
            },
            animate: r.get::<u8>(&ANIMATE)? != 0,
            ppm: PpmSettings {
                photons_per_pass: r.get(&PHOTONS_PER_PASS)?,
                max_photons: usize::try_from(max_photons)
                    .map_err(|_| bad(format!("max photons {max_photons}")))?,
                radius: r.get(&PHOTON_RADIUS)?,
                alpha: r.get(&PHOTON_ALPHA)?,
            },
            scene: SceneSource {
                kind,
                spec,
                defines,
            },
        })
    }
}
