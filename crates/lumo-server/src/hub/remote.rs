//! The hub's side of remote render workers: telling them each new epoch, what they are
//! welcomed with, and merging their checked sample batches into the viewers' stream.

use axum::body::Bytes;

use super::{broadcast, lock, to_wire, Hub, HubState, SAMPLES_PER_MESSAGE};
use crate::outbox::{Kind, Outgoing};
use crate::protocol::remote::{EpochUpdate, Welcome};
use crate::protocol::{Edit, ErrorCode, Mode, ProtocolError, SampleBatch, Stream};
use crate::remote::{RemoteConfig, RemoteSet, RemoteWorkerStats};

/// What [`Hub::merge_remote`] did with a remote worker's batch.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Merged {
    /// Sent to every viewer.
    Accepted {
        /// Camera samples in it (0 for the light stream).
        samples: u64,
        /// Light paths it accounts for.
        light_paths: u64,
        /// Its size.
        bytes: u64,
    },
    /// Dropped: its epoch is over (or the hub is not rendering it: paused, frame mode).
    Old {
        /// The batch's epoch.
        epoch: u32,
        /// The hub's.
        current: u32,
    },
}

impl Hub {
    /// Tells the remote workers about the epoch `st` now renders (after `edits`, posed at
    /// `time`).
    pub(super) fn announce(&self, st: &HubState, time: Option<f32>, edits: &[Edit]) {
        let state = EpochUpdate {
            epoch: st.epoch as u32,
            camera: to_wire(&st.job.camera),
            integrator: st.job.integrator,
            mode: st.job.mode,
            rendering: !st.paused && st.job.mode == Mode::Progressive,
            time,
        };
        self.remote.announce(state, edits);
    }

    /// The remote workers' settings, if they are on.
    pub fn remote_config(&self) -> Option<&RemoteConfig> {
        self.remote.config()
    }

    /// The remote workers connected now and their counters.
    pub fn remote_workers(&self) -> Vec<RemoteWorkerStats> {
        self.remote.stats()
    }

    /// The last log lines about remote workers (joins, refusals, departures).
    pub fn remote_log(&self) -> Vec<String> {
        self.remote.log_lines()
    }

    pub(crate) fn remote(&self) -> &RemoteSet {
        &self.remote
    }

    /// The hub's seed (remote workers' seeds are derived from it).
    pub(crate) fn seed(&self) -> u32 {
        self.config.seed
    }

    /// The WELCOME of worker `worker` with seed `seed` (None when remote workers are off).
    pub(crate) fn welcome(&self, worker: u32, seed: u32) -> Option<Welcome> {
        Some(Welcome {
            worker,
            seed,
            width: self.config.width as u32,
            height: self.config.height as u32,
            path: self.config.path,
            animate: self.config.animation.is_some(),
            ppm: self.config.ppm,
            scene: self.remote.config()?.scene.clone(),
        })
    }

    /// Merges a remote worker's SAMPLES message into the viewers' stream: checked (its
    /// samples finite with weight 1, at most [`SAMPLES_PER_MESSAGE`], a stream the current
    /// integrator makes, light paths only on the light stream) and, when it belongs to the
    /// epoch rendering now, sent to every viewer as it is. A batch of an earlier epoch (or
    /// while the hub is not rendering samples) is dropped; an error means the worker sent
    /// what no worker of this build sends (an epoch not begun yet, a bad value), and nothing
    /// of the batch was used.
    pub fn merge_remote(&self, msg: Bytes) -> Result<Merged, ProtocolError> {
        let (batch, count) = SampleBatch::check_packed(&msg, SAMPLES_PER_MESSAGE)?;
        let invalid = |m: String| Err(ProtocolError::new(ErrorCode::InvalidValue, m));
        if batch.stream == Stream::Camera && batch.light_paths != 0 {
            return invalid("a camera batch with light paths".into());
        }
        let mut st = lock(&self.state);
        let current = st.epoch as u32;
        if batch.epoch > current {
            return invalid(format!(
                "samples of epoch {} which has not begun (current {current})",
                batch.epoch
            ));
        }
        if batch.epoch < current || st.paused || st.job.mode != Mode::Progressive {
            return Ok(Merged::Old {
                epoch: batch.epoch,
                current,
            });
        }
        let streams = st.job.integrator.streams();
        if !streams[batch.stream as usize] {
            return invalid(format!(
                "{} samples under integrator {}",
                batch.stream.name(),
                st.job.integrator.name()
            ));
        }
        let (samples, light_paths) = match batch.stream {
            Stream::Camera => (count as u64, 0),
            Stream::Light => (0, batch.light_paths as u64),
        };
        st.remote_counts.0 += samples;
        st.remote_counts.1 += light_paths;
        let bytes = msg.len() as u64;
        broadcast(
            &st,
            &Outgoing {
                kind: Kind::Data(current),
                bytes: msg,
            },
        );
        Ok(Merged::Accepted {
            samples,
            light_paths,
            bytes,
        })
    }
}
