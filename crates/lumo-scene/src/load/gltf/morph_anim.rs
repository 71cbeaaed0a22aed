//! Animated morph-target weights (a channel whose path is `weights`).

use gltf::accessor::Dimensions;

use super::GltfReader;
use crate::animation::{Interpolation, WeightsChannel};
use crate::load::LoadError;

impl GltfReader<'_, '_> {
    /// The weights channel `ch` (driving rig node `node`), checked against its mesh's morph
    /// targets; `None` (with a warning) when the node has no morph targets to drive.
    pub(super) fn weights_channel(
        &mut self,
        ch: &gltf::animation::Channel,
        node: usize,
        label: &str,
    ) -> Result<Option<WeightsChannel>, LoadError> {
        let target = ch.target().node();
        let count = target
            .mesh()
            .and_then(|m| self.deform.targets.get(&m.index()).copied())
            .unwrap_or(0);
        if count == 0 {
            self.diag.warn(
                self.at(label.to_string()),
                format!(
                    "drives the morph weights of node {}, whose mesh has no morph targets; \
                     ignored (point the channel at the node with the morphing mesh)",
                    target.index()
                ),
            )?;
            return Ok(None);
        }
        let sampler = ch.sampler();
        self.check_accessor(&sampler.input(), &[Dimensions::Scalar], "animation input")?;
        self.check_accessor(&sampler.output(), &[Dimensions::Scalar], "animation output")?;
        let interpolation = super::interpolation(sampler.interpolation());
        let buffers = &self.buffers;
        let reader = ch.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let times: Vec<f32> = reader
            .read_inputs()
            .map(|i| i.collect())
            .unwrap_or_default();
        use gltf::animation::util::ReadOutputs;
        let values: Vec<f32> = match reader.read_outputs() {
            Some(ReadOutputs::MorphTargetWeights(it)) => it.into_f32().collect(),
            _ => Vec::new(),
        };
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        let increasing = times
            .windows(2)
            .all(|w| w[1].partial_cmp(&w[0]) == Some(std::cmp::Ordering::Greater));
        let problem = if !increasing || times.iter().any(|t| !t.is_finite()) {
            Some(format!(
                "its {} key times must be finite and increase",
                times.len()
            ))
        } else if values.len() != times.len() * per_key * count {
            Some(format!(
                "{} key times and {} weights do not fit node {}'s {count} morph targets \
                 ({per_key} × {count} weights per key for {interpolation:?}); give one weight \
                 per target per key",
                times.len(),
                values.len(),
                target.index()
            ))
        } else {
            values
                .iter()
                .position(|v| !v.is_finite())
                .map(|i| format!("weight {i} is {}; give every key finite weights", values[i]))
        };
        if let Some(problem) = problem {
            return Err(LoadError::invalid(self.at(label.to_string()), problem));
        }
        Ok(Some(WeightsChannel {
            node,
            interpolation,
            times,
            count,
            values,
        }))
    }
}
