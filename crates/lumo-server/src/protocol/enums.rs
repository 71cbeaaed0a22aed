//! The enumerations that travel as one byte: integrator, mode and sample stream. Each is
//! defined once, with its wire codes, the names the viewer uses and the labels of its menus;
//! `web/protocol_layout.js` is generated from these tables.

use super::layout::wire_enum;

wire_enum! {
    /// Which integrator feeds the sample streams.
    pub enum Integrator: u8, "integrator" {
        /// Path tracer: camera stream only.
        Path = 0, "path", "path";
        /// Light tracer: light stream only.
        Light = 1, "light", "light";
        /// Both, each weighted ½ so their sum estimates the image once.
        Both = 2, "both", "both";
        /// Bidirectional path tracing: camera-side strategies on the camera stream, light
        /// vertices seen by the camera (t = 1) on the light stream, one light path per sample.
        Bdpt = 3, "bdpt", "bidirectional";
        /// One-pass progressive photon mapping: camera stream only, gathering from a photon
        /// map that photon batches grow in proportion to the samples.
        Ppm = 4, "ppm", "photon mapping";
    }
}

impl Integrator {
    /// The integrators of lumo-render's table that this mode runs: one, or for `Both` the
    /// path and light tracers. Capabilities (spectral, media, streams) follow from theirs.
    pub const fn parts(self) -> &'static [lumo_render::Integrator] {
        use lumo_render::Integrator as T;
        match self {
            Integrator::Path => &[T::Path],
            Integrator::Light => &[T::Light],
            Integrator::Both => &[T::Path, T::Light],
            Integrator::Bdpt => &[T::Bdpt],
            Integrator::Ppm => &[T::Ppm],
        }
    }

    /// The mode that runs the table's integrator `i` alone (`None` where the server does not
    /// offer it: it feeds no sample stream).
    pub fn from_table(i: lumo_render::Integrator) -> Option<Integrator> {
        Integrator::ALL
            .iter()
            .copied()
            .find(|m| m.parts() == [i] && m.name() == i.name())
    }

    /// Whether every integrator of the mode transports light through media.
    pub fn renders_media(self) -> bool {
        self.parts().iter().all(|i| i.caps().media)
    }

    /// Whether every integrator of the mode transports light spectrally.
    pub fn spectral(self) -> bool {
        self.parts().iter().all(|i| i.caps().spectral)
    }

    /// The sample streams the mode feeds: `[camera, light]`.
    pub fn streams(self) -> [bool; 2] {
        let any =
            |f: fn(lumo_render::Capabilities) -> bool| self.parts().iter().any(|i| f(i.caps()));
        [any(|c| c.camera_stream), any(|c| c.light_stream)]
    }
}

wire_enum! {
    /// What the server sends: progressive samples or filtered frames.
    pub enum Mode: u8, "mode" {
        /// Sample streams for the viewer's progressive reconstruction.
        Progressive = 0, "progressive", "progressive";
        /// Whole frames: the running mean of 1-spp frames filtered by edge-avoiding À-Trous.
        Atrous = 1, "atrous", "À-Trous frames";
        /// Whole frames: the same mean filtered by the guided filter.
        Guided = 2, "guided", "guided frames";
    }
}

wire_enum! {
    /// Which sample stream a batch belongs to.
    pub enum Stream: u8, "stream" {
        /// Camera samples: pixel = Σ w·c / Σ w.
        Camera = 0, "camera", "camera";
        /// Light samples: pixel = Σ filtered c / light paths.
        Light = 1, "light", "light";
    }
}

wire_enum! {
    /// What a PICK hit: nothing, an object (a mesh instance and its material) or a light.
    pub enum PickTarget: u8, "pickTarget" {
        /// The ray left the scene (or the message is a viewer's request).
        Nothing = 0, "nothing", "nothing";
        /// A mesh instance: movable, with its material's base colour and emission.
        Object = 1, "object", "object";
        /// A point or spot light near the clicked pixel: movable, with its intensity.
        Light = 2, "light", "light";
    }
}

wire_enum! {
    /// What an EDIT changes; `value` holds the new absolute value.
    pub enum EditOp: u8, "editOp" {
        /// Instance `index`'s translation (world units): the object moves there.
        MoveInstance = 0, "moveInstance", "move object";
        /// Point or spot light `index`'s position (world units).
        MoveLight = 1, "moveLight", "move light";
        /// Light `index`'s intensity (point, spot: W/sr per channel; directional: irradiance).
        LightIntensity = 2, "lightIntensity", "light intensity";
        /// Material `index`'s emitted radiance (an area light's intensity), per channel.
        Emission = 3, "emission", "emission";
        /// Material `index`'s base colour (diffuse reflectance, a plastic's diffuse layer, a
        /// mirror's reflectance), linear RGB in [0, 1]; a texture is replaced by the colour.
        BaseColor = 4, "baseColor", "base colour";
    }
}
