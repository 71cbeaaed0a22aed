//! The light choice of next-event estimation re-weighed per light group: by default lights are
//! chosen in proportion to an estimate of power, which over-rates a light that most of the
//! scene does not see (a sun over a roof slot: its power is irradiance × the scene's whole
//! disk). [`Lights::select_by_groups`] mixes measured shares (the light pilot,
//! `crate::light_pilot`) with power.
//!
//! The new probabilities replace `choice` and its alias table, the one distribution that
//! [`Lights::sample`], the lane choices of the wavefront and every density lookup
//! ([`Lights::triangle_pdf`], [`Lights::environment_pdf`]) read, so every integrator's
//! next-event estimation and MIS stay consistent. The particle choice of the light tracer and
//! BDPT (`emission_choice`) and the direct-light split's (`area_choice`) stay by power: they
//! sample other integrals (where light leaves the lights; a ratio estimator's unshadowed half).

use glam::Vec2;

use super::distribution::{AliasTable, Distribution1d};
use super::{LightSample, Lights};

/// Measured shares of the light groups, kept so that [`Lights::update`] can re-apply them to
/// the moved lights' new powers.
#[derive(Clone, Debug)]
pub(super) struct Selection {
    /// Per group, its measured share (non-negative, not all zero).
    shares: Vec<f64>,
    /// The weight of power in the mixture, in (0, 1].
    mix: f32,
}

/// Why [`Lights::select_by_groups`] kept the choice by power.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SelectionRefusal {
    /// The shares are not one per group ([`Lights::group_count`]).
    WrongLength,
    /// The shares are all zero, or one is negative or not finite.
    NoShares,
    /// The mixing weight is not in (0, 1]: a light with power could get probability 0.
    BadMix,
    /// No light has power: the choice is uniform and stays so.
    NoPower,
}

impl std::fmt::Display for SelectionRefusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::WrongLength => "the shares are not one per light group",
            Self::NoShares => "the shares are all zero, negative or not finite",
            Self::BadMix => "the weight of power is not in (0, 1]",
            Self::NoPower => "no light has power",
        })
    }
}

impl std::error::Error for SelectionRefusal {}

impl Lights {
    /// Number of light groups: each emissive instance (all its triangles, or its exact shape)
    /// is one group, and so is each point, spot and directional light and the environment.
    pub fn group_count(&self) -> usize {
        self.group_starts.len()
    }

    /// The lights of group `g`, as a range of light indices (empty for a group out of range).
    fn group_range(&self, g: usize) -> std::ops::Range<usize> {
        let Some(&start) = self.group_starts.get(g) else {
            return 0..0;
        };
        let end = self
            .group_starts
            .get(g + 1)
            .map_or(self.lights.len(), |&e| e as usize);
        start as usize..end
    }

    /// Per group, the choice among its lights by power (the pilot samples a group through
    /// it, [`Lights::sample_in_group`]).
    pub fn group_choices(&self) -> Vec<Distribution1d> {
        (0..self.group_count())
            .map(|g| Distribution1d::new(&self.power[self.group_range(g)]))
            .collect()
    }

    /// A point on a light of group `g` seen from `p`, the light chosen by power within the
    /// group (`choices` from [`Lights::group_choices`]): the sample's weight and density hold
    /// the choice within the group only, so it estimates the whole group's light at `p`.
    pub fn sample_in_group(
        &self,
        choices: &[Distribution1d],
        g: usize,
        p: glam::Vec3,
        u_choice: f32,
        u: Vec2,
    ) -> Option<LightSample> {
        let choice = choices.get(g).filter(|c| !c.is_empty())?;
        let (k, _) = choice.sample(u_choice);
        let pick = choice.pmf(k);
        if pick <= 0.0 {
            return None;
        }
        let index = self.group_range(g).start + k;
        self.sample_chosen(index, pick, self.lights.get(index)?, p, u)
    }

    /// The probability with which [`Lights::sample`] picks each light (the densities of the
    /// MIS lookups hold the same).
    pub fn selection_pmf(&self) -> Vec<f32> {
        (0..self.lights.len()).map(|i| self.choice.pmf(i)).collect()
    }

    /// The probability with which [`Lights::sample`] picks a light of each group.
    pub fn group_pmf(&self) -> Vec<f32> {
        (0..self.group_count())
            .map(|g| self.group_range(g).map(|i| self.choice.pmf(i)).sum())
            .collect()
    }

    /// Whether the choice is by power ([`Lights::new`]) rather than by measured shares.
    pub fn selection_is_power(&self) -> bool {
        self.selection.is_none()
    }

    /// Chooses each light with probability `(1 − mix)·s_g·P_i/P_g + mix·P_i/P`, where `s_g`
    /// is group g's share of `shares` (normalised), `P_i` the light's power, `P_g` its group's
    /// and `P` all lights'. The power term keeps every light with power at a probability of
    /// at least `mix` times its power share, so no light that can contribute is left out
    /// (the estimate stays unbiased whatever the shares say); within a group the choice stays
    /// by power. On a refusal the choice is left as it was.
    pub fn select_by_groups(&mut self, shares: &[f64], mix: f32) -> Result<(), SelectionRefusal> {
        if shares.len() != self.group_count() {
            return Err(SelectionRefusal::WrongLength);
        }
        if !(mix > 0.0 && mix <= 1.0) {
            return Err(SelectionRefusal::BadMix);
        }
        let valid = shares.iter().all(|s| s.is_finite() && *s >= 0.0);
        let total: f64 = shares.iter().sum();
        if !valid || total <= 0.0 {
            return Err(SelectionRefusal::NoShares);
        }
        let power_total: f64 = self.power.iter().map(|&w| clean(w)).sum();
        if power_total <= 0.0 {
            return Err(SelectionRefusal::NoPower);
        }
        let mut weights = vec![0.0f32; self.lights.len()];
        for (g, share) in shares.iter().enumerate() {
            let range = self.group_range(g);
            let group_power: f64 = self.power[range.clone()].iter().map(|&w| clean(w)).sum();
            for i in range {
                let w = clean(self.power[i]);
                let within = if group_power > 0.0 {
                    w / group_power
                } else {
                    0.0
                };
                let p =
                    (1.0 - mix as f64) * (share / total) * within + mix as f64 * (w / power_total);
                weights[i] = p as f32;
            }
        }
        self.choice = Distribution1d::new(&weights);
        self.alias = AliasTable::new(&self.choice);
        self.selection = Some(Selection {
            shares: shares.to_vec(),
            mix,
        });
        Ok(())
    }

    /// Back to the choice by power of [`Lights::new`].
    pub fn select_by_power(&mut self) {
        self.choice = Distribution1d::new(&self.power);
        self.alias = AliasTable::new(&self.choice);
        self.selection = None;
    }

    /// Re-applies a selection kept across [`Lights::update`] (the groups are the same where
    /// the scene's structure is; otherwise the choice stays by power).
    pub(super) fn reapply(&mut self, selection: Option<Selection>) {
        if let Some(s) = selection {
            // A refusal (the groups changed, or no power is left) keeps the choice by power.
            let _ = self.select_by_groups(&s.shares, s.mix);
        }
    }
}

/// A power as a weight: non-finite and negative values count as 0 (as `Distribution1d` does).
fn clean(w: f32) -> f64 {
    if w.is_finite() && w > 0.0 {
        w as f64
    } else {
        0.0
    }
}
