"""`CentaurEnv` (a `gymnasium.Env`) and `CentaurVectorEnv` (a `gymnasium.vector.VectorEnv`
whose batch steps in Rust threads) over the native environments.

Options are the `[env]` keys of a run's TOML file (`randomize=False`, `max_episode_steps=500`,
`healthy_reward=5.0`, …; see the README's table): a key the environment does not have, or
a bad value, raises `centaur.CentaurError` naming it.

`learner="sac"` (any `centaur train --algo` name) builds a hybrid (`*-Residual-*`) with that
learner's residual preset, as `centaur train --algo sac` does; the default is PPO's. They
differ on Walker2d: PPO's residual is bounded at 1.0, a bound that rises from 1/30 of it over
the first 100k training samples the environment is told (`set_training_samples`; never
told, it acts at the full bound), on the walk at 0.6 of its period; the off-policy
learners' (SAC, TD3, DDPG) at 0.1 on the walk's own period.
"""

from __future__ import annotations

import json
import os
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from centaur import _native

_SEED_BOUND = 2**63
# The environment's own episode limit when Gymnasium's TimeLimit wrapper keeps time
# instead (2^53 steps: never reached).
_NO_LIMIT = 2**53


def _native_name(name: str | None, body: str | os.PathLike | None) -> str:
    if name is None:  # centaur/Modular-v0
        if body is None:
            raise _native.CentaurError("centaur/Modular-v0 needs body=PATH (a modular robot's JSON body file)")
        return f"modular:{os.fspath(body)}"
    if body is not None:
        raise _native.CentaurError(f"body= is only for centaur/Modular-v0, not `{name}`")
    return name


def _length_option(name: str, options: dict[str, Any], steps: int | None) -> None:
    """Puts the episode length `steps` into `options` (None: the preset's)."""
    if steps is not None:
        options["max_episode_steps"] = steps


def _settings(options: dict[str, Any]) -> str | None:
    """The `[env]` table as JSON (None: the preset as it is)."""
    if not options:
        return None

    def plain(v: Any) -> Any:
        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, (tuple, list, np.ndarray)):
            return [plain(x) for x in v]
        return v

    table = {k: plain(v) for k, v in options.items()}
    for key, value in table.items():
        for x in value if isinstance(value, list) else [value]:
            if isinstance(x, float) and not np.isfinite(x):
                raise _native.CentaurError(f"env option {key} is {x}, expected a finite number")
    return json.dumps(table, allow_nan=False)


def _spaces(described: tuple) -> tuple[str, spaces.Box, spaces.Box, int, float, list[str]]:
    name, (olo, ohi), (alo, ahi), max_steps, dt, terms = described
    obs = spaces.Box(olo, ohi, dtype=np.float32)
    act = spaces.Box(alo, ahi, dtype=np.float32)
    return name, obs, act, max_steps, dt, terms


def _check_reset_options(options: dict | None) -> None:
    if options:
        raise _native.CentaurError(
            f"reset(options=...) takes no options ({sorted(options)}); pass env options to gymnasium.make"
        )


class CentaurEnv(gymnasium.Env):
    """One Centaur environment. `info` holds `reward_terms` (a dict of the terms whose
    weighted sum is the reward), `forward_velocity` (m/s), `energy` (J spent by the
    actuators in the step), `foot_contacts` (a bit per foot) and `unstable` (the simulation
    blew up and the episode was ended)."""

    def __init__(
        self,
        name: str | None = None,
        render_mode: str | None = None,
        body: str | os.PathLike | None = None,
        max_episode_steps: int | None = None,
        gymnasium_time_limit: bool = False,
        learner: str | None = None,
        **options: Any,
    ):
        if render_mode is not None:
            raise _native.CentaurError(
                f"render_mode={render_mode!r}: Centaur envs do not render (record MCAP files with `centaur eval --record`)"
            )
        self.render_mode = None
        name = _native_name(name, body)
        # Made by gymnasium.make: its TimeLimit wrapper keeps time.
        _length_option(name, options, _NO_LIMIT if gymnasium_time_limit else max_episode_steps)
        self._adopt(_native.Env(name, _settings(options), learner))

    @classmethod
    def from_checkpoint(cls, path: str | os.PathLike) -> CentaurEnv:
        """The environment a checkpoint (a run directory or its `checkpoint` file) was trained
        on, rebuilt from what the checkpoint records alone: its environment, `[env]` settings
        and, for a hybrid, the whole setup it trained with (a spec's or a comparison's), so
        that `centaur.Policy.load(path)` acts in it as it was trained, with no option given.
        The episode limit is the environment's own."""
        env = cls.__new__(cls)
        env.render_mode = None
        env._adopt(_native.Env.from_checkpoint(os.fspath(path)))
        return env

    def _adopt(self, native: Any) -> None:
        self._env = native
        self.name, self.observation_space, self.action_space, self.max_episode_steps, self.dt, self.reward_term_names = (
            _spaces(self._env.describe())
        )
        self.metadata = {"render_modes": [], "render_fps": round(1.0 / self.dt)}
        self._seeded = False

    def set_training_samples(self, samples: int) -> None:
        """Tells the environment the learner's training samples so far: a hybrid whose preset
        has a rising residual bound (Walker2d's) follows them; one never told acts at the
        full bound, as fully trained. Centaur's own learners tell it; call it from another
        trainer (e.g. a Stable-Baselines3 callback at each rollout) to get the same gentle
        start."""
        self._env.set_training_samples(int(samples))

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        _check_reset_options(options)
        super().reset(seed=seed)
        if seed is None and not self._seeded:
            # Gymnasium's rule: an env never seeded draws its seed at random.
            seed = int(self.np_random.integers(_SEED_BOUND))
        obs = self._env.reset(None if seed is None else int(seed))
        self._seeded = True
        return obs, {}

    def step(self, action):
        action = np.ascontiguousarray(action, dtype=np.float32)
        if action.ndim != 1:
            raise _native.CentaurError(f"action has shape {action.shape}, expected {self.action_space.shape}")
        obs, reward, terminated, truncated, (terms, fv, energy, contacts, unstable) = self._env.step(action)
        info = {
            "reward_terms": dict(zip(self.reward_term_names, terms.tolist())),
            "forward_velocity": fv,
            "energy": energy,
            "foot_contacts": contacts,
            "unstable": unstable,
        }
        return obs, reward, terminated, truncated, info


class CentaurVectorEnv(VectorEnv):
    """`num_envs` copies of an environment stepped together in Rust threads
    (`num_threads`, default: one per core up to `num_envs`), numpy batches in and out.

    Auto-reset is same-step (`AutoresetMode.SAME_STEP`, as Stable-Baselines3 and EnvPool
    do): an environment whose episode ends is reset in that step; its final observation is
    `infos["final_obs"][i]` (with `infos["_final_obs"][i]` set) and the returned
    observation starts the next episode. Environment `i` is reset with seed `seed + i`, and
    the results do not depend on `num_threads`."""

    def __init__(
        self,
        name: str | None = None,
        num_envs: int = 1,
        num_threads: int | None = None,
        render_mode: str | None = None,
        body: str | os.PathLike | None = None,
        max_episode_steps: int | None = None,
        gymnasium_time_limit: bool = False,
        learner: str | None = None,
        **options: Any,
    ):
        # `gymnasium_time_limit` is the spec's note for gymnasium.make; gymnasium.make_vec
        # passes the spec's length as `max_episode_steps`, kept by the environments.
        del gymnasium_time_limit
        if render_mode is not None:
            raise _native.CentaurError(f"render_mode={render_mode!r}: Centaur envs do not render")
        if num_threads is None:
            num_threads = min(num_envs, os.cpu_count() or 1)
        name = _native_name(name, body)
        _length_option(name, options, max_episode_steps)
        self._env = _native.VecEnv(name, int(num_envs), int(num_threads), _settings(options), learner)
        self.num_envs = int(num_envs)
        self.num_threads = int(num_threads)
        (
            self.name,
            self.single_observation_space,
            self.single_action_space,
            self.max_episode_steps,
            self.dt,
            self.reward_term_names,
        ) = _spaces(self._env.describe())
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {
            "autoreset_mode": AutoresetMode.SAME_STEP,
            "render_modes": [],
            "render_fps": round(1.0 / self.dt),
        }
        self.render_mode = None
        self._seeded = False
        self._all = np.ones(self.num_envs, dtype=bool)
        self._all.flags.writeable = False

    def set_training_samples(self, samples: int) -> None:
        """As `CentaurEnv.set_training_samples`, for every environment."""
        self._env.set_training_samples(int(samples))

    def reset(self, *, seed: int | list[int] | None = None, options: dict | None = None):
        _check_reset_options(options)
        if isinstance(seed, (list, tuple)):
            # Environment i takes seed + i; a list is accepted when it says exactly that.
            first = int(seed[0]) if len(seed) else 0
            if list(seed) != list(range(first, first + self.num_envs)):
                raise _native.CentaurError(
                    f"a list of seeds must be consecutive ([s, s+1, …], {self.num_envs} of them): environment i is reset with seed s + i"
                )
            seed = first
        super().reset(seed=seed)
        if seed is None:
            # Not seeded, or a new episode batch: draw from the vector env's generator.
            seed = int(self.np_random.integers(_SEED_BOUND - self.num_envs))
        obs = self._env.reset(int(seed))
        self._seeded = True
        return obs, {}

    def step(self, actions):
        actions = np.ascontiguousarray(actions, dtype=np.float32)
        if actions.shape != self.action_space.shape:
            raise _native.CentaurError(f"actions have shape {actions.shape}, expected {self.action_space.shape}")
        obs, rewards, terminated, truncated, final_obs, (terms, fv, energy, contacts, unstable), episodes = (
            self._env.step(actions)
        )
        self.last_final_obs, self.last_episodes = final_obs, episodes
        all_ = self._all
        infos: dict[str, Any] = {
            "reward_terms": terms,
            "_reward_terms": all_,
            "forward_velocity": fv,
            "_forward_velocity": all_,
            "energy": energy,
            "_energy": all_,
            "foot_contacts": contacts,
            "_foot_contacts": all_,
            "unstable": unstable,
            "_unstable": all_,
        }
        done = terminated | truncated
        if done.any():
            finals = np.empty(self.num_envs, dtype=object)
            for i in np.flatnonzero(done):
                finals[i] = final_obs[i]
            infos["final_obs"] = finals
            infos["_final_obs"] = done
            # As gymnasium.wrappers.vector.RecordEpisodeStatistics reports them (no time).
            ret, length = np.zeros(self.num_envs), np.zeros(self.num_envs, dtype=np.int64)
            for i, r, n in episodes:
                ret[i], length[i] = r, n
            infos["episode"] = {"r": ret, "l": length, "_r": done, "_l": done}
            infos["_episode"] = done
        return obs, rewards, terminated, truncated, infos
