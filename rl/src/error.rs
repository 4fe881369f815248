//! The crate's error type: bad configuration, incompatible environments, environment
//! failures, unreadable checkpoints, diverged training.

use crate::checkpoint::CheckpointError;
use centaur_gym::EnvError;

/// Why a learner refused to start or stopped.
#[derive(Debug, thiserror::Error)]
pub enum RlError {
    /// A configuration value is out of its valid range.
    #[error("invalid {algo} config: `{field}` = {value}: {reason}")]
    InvalidConfig {
        /// Algorithm name.
        algo: &'static str,
        /// Field name as in the TOML file.
        field: &'static str,
        /// The offending value.
        value: String,
        /// What was expected.
        reason: &'static str,
    },
    /// The environment does not fit the learner (spaces, number of environments).
    #[error("environment does not fit the {algo} learner: {reason}")]
    Incompatible {
        /// Algorithm name.
        algo: &'static str,
        /// What differs.
        reason: String,
    },
    /// A policy used on an environment of other dimensions.
    #[error("a policy for {} observations and {} actions used on an environment with {} and {}", policy.0, policy.1, env.0, env.1)]
    PolicyMismatch {
        /// The policy's observation and action dimensions.
        policy: (usize, usize),
        /// The environment's.
        env: (usize, usize),
    },
    /// The environment refused a call.
    #[error("environment error: {0}")]
    Env(#[from] EnvError),
    /// A checkpoint could not be written or read.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// A loss or parameter became NaN or infinite.
    #[error("{algo} diverged at update {update}: {what} is not finite")]
    Diverged {
        /// Algorithm name.
        algo: &'static str,
        /// Update index.
        update: u64,
        /// What became non-finite.
        what: &'static str,
    },
}

/// `Err(InvalidConfig)` unless `ok`.
pub(crate) fn check(
    ok: bool,
    algo: &'static str,
    field: &'static str,
    value: impl std::fmt::Debug,
    reason: &'static str,
) -> Result<(), RlError> {
    if ok { Ok(()) } else { Err(RlError::InvalidConfig { algo, field, value: format!("{value:?}"), reason }) }
}

/// The largest exploration or target-policy noise σ (and noise clip) a learner takes, in
/// units of the policy's `[-1, 1]` output: beyond a few ranges every noisy action is clipped
/// to a bound, so larger values (`1e300` in the reliability probe) are typos, not settings.
pub const MAX_NOISE: f64 = 10.0;

/// The largest entropy coefficient |c| (PPO, A2C): the bonus is per unit of the policy
/// loss, whose advantages are normalised; above 1 it drowns the objective.
pub const MAX_ENT_COEF: f64 = 1.0;

/// The largest value-loss coefficient (PPO, A2C).
pub const MAX_VF_COEF: f64 = 100.0;

/// The smallest gradient-norm clip (PPO, A2C): below it every update is clipped to nothing.
pub const MIN_MAX_GRAD_NORM: f64 = 1e-6;

/// The smallest observation and reward clip (in running standard deviations): below it
/// the normalised signal is clipped away.
pub const MIN_NORM_CLIP: f64 = 1e-3;

/// Checks the on-policy learners' (PPO, A2C) loss terms: the entropy and value-loss
/// coefficients and the gradient-norm clip.
pub(crate) fn check_loss_terms(
    algo: &'static str,
    ent_coef: f64,
    vf_coef: f64,
    max_grad_norm: f64,
) -> Result<(), RlError> {
    check(ent_coef.abs() <= MAX_ENT_COEF, algo, "ent_coef", ent_coef, "must be in [-1, 1]")?;
    check((0.0..=MAX_VF_COEF).contains(&vf_coef), algo, "vf_coef", vf_coef, "must be in [0, 100]")?;
    check(
        max_grad_norm.is_finite() && max_grad_norm >= MIN_MAX_GRAD_NORM,
        algo,
        "max_grad_norm",
        max_grad_norm,
        "must be at least 1e-6",
    )
}

/// Checks the observation and reward normalisers' clips (in running standard deviations).
pub(crate) fn check_norm_clips(algo: &'static str, clip_obs: f64, clip_reward: f64) -> Result<(), RlError> {
    check(clip_obs >= MIN_NORM_CLIP, algo, "clip_obs", clip_obs, "must be at least 1e-3")?;
    check(clip_reward >= MIN_NORM_CLIP, algo, "clip_reward", clip_reward, "must be at least 1e-3")
}

/// Checks an optional `critic_learning_rate`: unset, or finite and positive.
pub(crate) fn check_critic_lr(algo: &'static str, lr: Option<f64>) -> Result<(), RlError> {
    check(
        lr.is_none_or(|lr| lr.is_finite() && lr > 0.0),
        algo,
        "critic_learning_rate",
        format_args!("{}", lr.unwrap_or_default()),
        "must be positive",
    )
}

/// The most `f32` values one buffer of a learner may hold (2^30, 4 GiB): a rollout or replay
/// buffer, a batch's activations. Larger settings are refused before anything is allocated.
pub const MAX_BUFFER_FLOATS: usize = 1 << 30;

/// The most parameters one network may have (2^27: with its gradient and Adam's two moments,
/// 2 GiB).
pub const MAX_NET_PARAMS: usize = 1 << 27;

/// Checks, with overflow-checked products, that the buffers a learner is about to allocate
/// are within [`MAX_BUFFER_FLOATS`] and its networks within [`MAX_NET_PARAMS`]: `rows` is the
/// storage (`field`, `a`, `b`: `a × b` rows of `row_floats` values each); `nets` the hidden
/// layers of each network between inputs of at most `obs_dim + act_dim` and outputs of at
/// most `2 act_dim + 1`; `batch` the largest batch pushed through them.
pub(crate) fn check_sizes(
    algo: &'static str,
    rows: (&'static str, usize, usize),
    row_floats: usize,
    nets: &[(&'static str, &[usize])],
    obs_dim: usize,
    act_dim: usize,
    batch: usize,
) -> Result<(), RlError> {
    let (field, a, b) = rows;
    let storage = a.checked_mul(b).and_then(|r| r.checked_mul(row_floats));
    check(
        storage.is_some_and(|n| n <= MAX_BUFFER_FLOATS),
        algo,
        field,
        format_args!("{a} × {b} rows × {row_floats} values"),
        "needs more than 2^30 values (4 GiB) of storage",
    )?;
    let io = obs_dim.saturating_add(act_dim).saturating_add(act_dim).saturating_add(1);
    check(
        batch.checked_mul(io).is_some_and(|n| n <= MAX_BUFFER_FLOATS),
        algo,
        "batch_size",
        batch,
        "needs more than 2^30 values (4 GiB) per batch",
    )?;
    for &(field, hidden) in nets {
        let sizes: Vec<usize> =
            [&[obs_dim.saturating_add(act_dim)][..], hidden, &[act_dim.saturating_mul(2).saturating_add(1)]]
                .concat();
        let params = sizes.windows(2).try_fold(0usize, |sum, w| {
            w[0].checked_add(1).and_then(|i| i.checked_mul(w[1])).and_then(|p| sum.checked_add(p))
        });
        check(
            params.is_some_and(|p| p <= MAX_NET_PARAMS),
            algo,
            field,
            hidden,
            "gives a network of more than 2^27 parameters",
        )?;
        let width = hidden.iter().try_fold(0usize, |s, &h| s.checked_add(h));
        check(
            width.and_then(|w| w.checked_mul(batch)).is_some_and(|n| n <= MAX_BUFFER_FLOATS),
            algo,
            field,
            format_args!("{hidden:?} × batch {batch}"),
            "needs more than 2^30 activation values (4 GiB) per batch",
        )?;
    }
    Ok(())
}
