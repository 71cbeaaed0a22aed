//! STATS (0x12, server → viewer): the counters of the running render, a few times a second.

use super::error::ProtocolError;
use super::kind;
use super::layout::{Direction, Field, FieldType, Layout, Reader, Writer};

const EPOCH: Field = Field::one("epoch", 4, FieldType::U32, "epoch");
const VIEWERS: Field = Field::one("viewers", 8, FieldType::U32, "viewers connected");
const SAMPLES: Field = Field::one(
    "samples",
    12,
    FieldType::U64,
    "camera samples rendered in this epoch",
);
const LIGHT_PATHS: Field = Field::one(
    "lightPaths",
    20,
    FieldType::U64,
    "light paths traced in this epoch",
);
const RATE: Field = Field::one(
    "rate",
    28,
    FieldType::F32,
    "samples (camera samples + light paths) per second, last interval",
);
const DROPPED: Field = Field::one(
    "dropped",
    32,
    FieldType::U32,
    "data messages dropped for this viewer because it read too slowly",
);

/// Counters sent a few times a second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    /// Epoch of the current render.
    pub epoch: u32,
    /// Viewers connected.
    pub viewers: u32,
    /// Camera samples rendered in this epoch.
    pub samples: u64,
    /// Light paths traced in this epoch.
    pub light_paths: u64,
    /// Camera samples plus light paths per second, over the last interval.
    pub rate: f32,
    /// Sample batches dropped for this viewer because it read too slowly.
    pub dropped: u32,
}

impl Stats {
    /// Field table of STATS.
    pub const LAYOUT: Layout = Layout::message(
        "STATS",
        kind::STATS,
        Direction::ToViewer,
        &[EPOCH, VIEWERS, SAMPLES, LIGHT_PATHS, RATE, DROPPED],
    );

    /// Encodes them.
    pub fn write(&self) -> Vec<u8> {
        let mut w = Writer::new(&Self::LAYOUT, 0);
        w.put(&EPOCH, self.epoch);
        w.put(&VIEWERS, self.viewers);
        w.put(&SAMPLES, self.samples);
        w.put(&LIGHT_PATHS, self.light_paths);
        w.put(&RATE, self.rate);
        w.put(&DROPPED, self.dropped);
        w.finish()
    }

    pub(super) fn decode(r: &Reader) -> Result<Self, ProtocolError> {
        Ok(Self {
            epoch: r.get(&EPOCH)?,
            viewers: r.get(&VIEWERS)?,
            samples: r.get(&SAMPLES)?,
            light_paths: r.get(&LIGHT_PATHS)?,
            rate: r.get(&RATE)?,
            dropped: r.get(&DROPPED)?,
        })
    }
}
