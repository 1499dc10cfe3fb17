//! A batch of swing environments stepped together, in parallel (rayon), with Gymnasium's autoreset
//! modes. Environment `i` of a batch seeded with `seed` is the single [`SwingEnv`] seeded with
//! `seed + i`, stepped with the same actions and reset as the mode says: the same episodes bit for
//! bit.

use super::{RewardTerms, StepOutcome, SwingEnv, SwingEnvSpec};
use brachia::Error;
use rayon::prelude::*;
use std::sync::Arc;

/// When an ended episode restarts (Gymnasium's `AutoresetMode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Autoreset {
    /// On the step after the one that ended it: that step ignores its action and returns the new
    /// episode's first observation, reward 0, neither terminated nor truncated.
    #[default]
    NextStep,
    /// On the step that ended it: the returned observation is the new episode's first; the last
    /// one of the ended episode is kept as the final observation.
    SameStep,
}

/// The outputs of one batch call (allocated once, overwritten by every call).
#[derive(Debug, Clone, Default)]
pub struct BatchOutput {
    /// Observations, `(envs, obs_dim)` row-major.
    pub obs: Vec<f32>,
    /// Rewards.
    pub reward: Vec<f64>,
    /// Terminated flags.
    pub terminated: Vec<bool>,
    /// Truncated flags.
    pub truncated: Vec<bool>,
    /// Reward terms.
    pub terms: Vec<RewardTerms>,
    /// Hand distance to the bar, m.
    pub distance_m: Vec<f64>,
    /// Final observations of the episodes that ended in this call (same-step autoreset), `(envs,
    /// obs_dim)`; meaningful where `ended` is true.
    pub final_obs: Vec<f32>,
    /// Which environments ended an episode in this call and were reset (same-step autoreset).
    pub ended: Vec<bool>,
}

/// Environments stepped together.
pub struct SwingBatch {
    envs: Vec<SwingEnv>,
    /// Which environments reset on the next step (next-step autoreset).
    pending: Vec<bool>,
    mode: Autoreset,
    obs_dim: usize,
    act_dim: usize,
}

impl SwingBatch {
    /// `count` environments of `spec`, environment `i` seeded with `seed + i`.
    pub fn new(
        spec: Arc<SwingEnvSpec>,
        count: usize,
        seed: u64,
        mode: Autoreset,
    ) -> Result<Self, Error> {
        if count == 0 || count > MAX_ENVS {
            return Err(Error::invalid(
                &spec.src,
                "num_envs",
                count,
                format!("must be 1..={MAX_ENVS}"),
            ));
        }
        let envs = (0..count as u64)
            .into_par_iter()
            .map(|i| SwingEnv::new(spec.clone(), seed.wrapping_add(i)))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(SwingBatch {
            pending: vec![false; count],
            obs_dim: spec.observation_dim(),
            act_dim: spec.action_dim(),
            envs,
            mode,
        })
    }

    /// Number of environments.
    pub fn len(&self) -> usize {
        self.envs.len()
    }

    /// Never empty (at least one environment).
    pub fn is_empty(&self) -> bool {
        self.envs.is_empty()
    }

    /// The environments.
    pub fn envs(&self) -> &[SwingEnv] {
        &self.envs
    }

    /// The autoreset mode.
    pub fn mode(&self) -> Autoreset {
        self.mode
    }

    /// An output buffer sized for this batch.
    pub fn output(&self) -> BatchOutput {
        let (m, d) = (self.envs.len(), self.obs_dim);
        BatchOutput {
            obs: vec![0.0; m * d],
            reward: vec![0.0; m],
            terminated: vec![false; m],
            truncated: vec![false; m],
            terms: vec![RewardTerms::default(); m],
            distance_m: vec![0.0; m],
            final_obs: vec![0.0; m * d],
            ended: vec![false; m],
        }
    }

    /// Reset every environment: environment `i` reseeded with `seed + i` (`None`: its generator
    /// continues), with `randomization` for this episode (`None`: the spec's). Writes the
    /// observations into `out.obs`.
    pub fn reset(
        &mut self,
        seed: Option<u64>,
        randomization: Option<&super::Randomization>,
        out: &mut BatchOutput,
    ) -> Result<(), Error> {
        let d = self.obs_dim;
        self.envs
            .par_iter_mut()
            .zip(out.obs.par_chunks_mut(d))
            .enumerate()
            .try_for_each(|(i, (env, obs))| {
                env.reset(seed.map(|s| s.wrapping_add(i as u64)), randomization)?;
                env.observe(obs);
                Ok::<(), Error>(())
            })?;
        self.pending.iter_mut().for_each(|p| *p = false);
        out.ended.iter_mut().for_each(|e| *e = false);
        Ok(())
    }

    /// One control period of every environment, `actions` `(envs, n - 1)` row-major. The whole call
    /// is refused (nothing stepped) when an action is not finite or the length is wrong.
    pub fn step(&mut self, actions: &[f64], out: &mut BatchOutput) -> Result<(), Error> {
        let (m, nu, d) = (self.envs.len(), self.act_dim, self.obs_dim);
        if actions.len() != m * nu {
            return Err(Error::invalid(
                &self.envs[0].spec().src,
                "actions",
                format!("{} values", actions.len()),
                format!("needs ({m}, {nu}) values"),
            ));
        }
        if let Some((k, a)) = actions.iter().enumerate().find(|(_, a)| !a.is_finite()) {
            return Err(Error::invalid(
                &self.envs[0].spec().src,
                format!("actions[{}, {}]", k / nu, k % nu),
                a,
                "must be finite (scaled to [-1, 1])",
            ));
        }
        let mode = self.mode;
        let per_thread = m.div_ceil(rayon::current_num_threads().max(1));
        self.envs
            .par_iter_mut()
            .zip(self.pending.par_iter_mut())
            .zip(actions.par_chunks(nu))
            .zip(out.obs.par_chunks_mut(d))
            .zip(out.final_obs.par_chunks_mut(d))
            .zip(out.reward.par_iter_mut())
            .zip(out.terminated.par_iter_mut())
            .zip(out.truncated.par_iter_mut())
            .zip(out.terms.par_iter_mut())
            .zip(out.distance_m.par_iter_mut())
            .zip(out.ended.par_iter_mut())
            .with_min_len(per_thread)
            .try_for_each(
                |((((((((((env, pending), a), obs), fin), r), te), tr), terms), dist), ended)| {
                    let o = step_one(env, pending, mode, a, obs, fin, ended)?;
                    *r = o.reward;
                    *te = o.terminated;
                    *tr = o.truncated;
                    *terms = o.terms;
                    *dist = o.distance_m;
                    Ok::<(), Error>(())
                },
            )
    }
}

/// Most environments in one batch.
pub const MAX_ENVS: usize = 65_536;

/// One environment's part of a batch step.
fn step_one(
    env: &mut SwingEnv,
    pending: &mut bool,
    mode: Autoreset,
    action: &[f64],
    obs: &mut [f32],
    fin: &mut [f32],
    ended: &mut bool,
) -> Result<StepOutcome, Error> {
    *ended = false;
    if *pending {
        env.reset(None, None)?;
        env.observe(obs);
        *pending = false;
        return Ok(StepOutcome::default());
    }
    let o = env.step(action)?;
    env.observe(obs);
    if o.terminated || o.truncated {
        match mode {
            Autoreset::NextStep => *pending = true,
            Autoreset::SameStep => {
                fin.copy_from_slice(obs);
                *ended = true;
                env.reset(None, None)?;
                env.observe(obs);
            }
        }
    }
    Ok(o)
}
