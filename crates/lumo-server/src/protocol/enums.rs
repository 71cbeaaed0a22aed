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
