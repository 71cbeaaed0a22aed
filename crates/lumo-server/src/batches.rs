//! A query's samples as SAMPLES messages: what the hub's pump sends viewers and what a remote
//! worker sends its hub, cut the same way.

use crate::hub::SAMPLES_PER_MESSAGE;
use crate::protocol::{SampleBatch, Stream};
use crate::streams::Sample;
use crate::worker::QueryBuffer;

/// The SAMPLES messages of `buf`'s samples, tagged with `epoch`: camera samples, then light
/// splats, [`SAMPLES_PER_MESSAGE`] per message. The light paths are spread over the light
/// messages in proportion to their splats, so a dropped message takes its share of the light
/// image's divisor with it; paths that hit nothing visible still go out (in a message of no
/// splats).
pub fn sample_messages(epoch: u32, buf: &QueryBuffer) -> Vec<Vec<u8>> {
    let mut out = Vec::new();
    for chunk in buf.camera.chunks(SAMPLES_PER_MESSAGE) {
        out.push(batch(epoch, Stream::Camera, chunk, 0));
    }
    let total = buf.light.len().max(1) as u64;
    let mut given = 0u64;
    let chunks: Vec<_> = buf.light.chunks(SAMPLES_PER_MESSAGE).collect();
    for (i, chunk) in chunks.iter().enumerate() {
        let paths = if i + 1 == chunks.len() {
            buf.light_paths - given
        } else {
            buf.light_paths * chunk.len() as u64 / total
        };
        given += paths;
        out.push(batch(epoch, Stream::Light, chunk, paths as u32));
    }
    if buf.light.is_empty() && buf.light_paths > 0 {
        out.push(batch(epoch, Stream::Light, &[], buf.light_paths as u32));
    }
    out
}

fn batch(epoch: u32, stream: Stream, samples: &[Sample], paths: u32) -> Vec<u8> {
    SampleBatch {
        epoch,
        stream,
        light_paths: paths,
    }
    .write(samples)
}
