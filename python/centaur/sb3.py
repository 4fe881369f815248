"""Stable-Baselines3 on Centaur: `CentaurSb3VecEnv`, an SB3 `VecEnv` over the native vector
env (the batch steps in Rust threads; SB3 sees what its `DummyVecEnv` of `Monitor`-wrapped
envs would give it).

    from stable_baselines3 import PPO
    from centaur.sb3 import CentaurSb3VecEnv

    env = CentaurSb3VecEnv("centaur/Minitaur-v0", num_envs=8, randomize=True)
    PPO("MlpPolicy", env).learn(200_000)

Needs `pip install "centaur[sb3]"` (stable-baselines3 and torch).
"""

from __future__ import annotations

import time
from typing import Any

import gymnasium
import numpy as np
from stable_baselines3.common.vec_env import VecEnv

from centaur import _native
from centaur._registration import ENV_IDS
from centaur.envs import CentaurVectorEnv


class CentaurSb3VecEnv(VecEnv):
    """`num_envs` copies of a Centaur environment (a `centaur/…` id, or a name as `centaur
    train --env` takes it) on `num_threads` Rust threads (default: one per core up to
    `num_envs`), with the `[env]` options as keywords.

    Same-step auto-reset as SB3 expects: a finished episode's last observation is
    `infos[i]["terminal_observation"]`, `infos[i]["TimeLimit.truncated"]` tells a time
    limit from a fall, and `infos[i]["episode"] = {"r", "l", "t"}` (as SB3's `Monitor`
    writes it) feeds SB3's `rollout/ep_rew_mean`. `seed(s)` makes environment i start
    from seed `s + i` at the next reset, as SB3's own vector envs do.
    """

    def __init__(self, env: str, num_envs: int = 1, num_threads: int | None = None, **options: Any):
        if options.get("max_episode_steps") is None and env in gymnasium.registry:
            options["max_episode_steps"] = gymnasium.spec(env).max_episode_steps
        # The native vector env under the Gymnasium one; SB3's API steps it directly.
        venv = CentaurVectorEnv(ENV_IDS.get(env, env), num_envs, num_threads, **options)
        self._env = venv._env
        self.max_episode_steps, self.dt, self.reward_term_names = (
            venv.max_episode_steps,
            venv.dt,
            venv.reward_term_names,
        )
        self.render_mode = None
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)
        self._actions: np.ndarray | None = None
        self._rng = np.random.default_rng()
        self._start = time.time()

    def reset(self) -> np.ndarray:
        seed = self._seeds[0]
        if seed is None:
            seed = int(self._rng.integers(2**63 - self.num_envs))
        obs = self._env.reset(int(seed))
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.ascontiguousarray(actions, dtype=np.float32).reshape(self.num_envs, -1)

    def step_wait(self):
        if self._actions is None:
            raise _native.CentaurError("step_wait called without step_async")
        obs, rewards, terminated, truncated, final_obs, _, episodes = self._env.step(self._actions)
        self._actions = None
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{"TimeLimit.truncated": bool(t and not te)} for t, te in zip(truncated, terminated)]
        for i in np.flatnonzero(dones):
            infos[i]["terminal_observation"] = final_obs[i]
        elapsed = round(time.time() - self._start, 6)
        for i, ret, length in episodes:
            infos[i]["episode"] = {"r": ret, "l": length, "t": elapsed}
        return obs, rewards.astype(np.float32), dones, infos

    def close(self) -> None:
        pass

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return [getattr(self, attr_name)] * len(self._get_indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        raise AttributeError(f"CentaurSb3VecEnv: the Rust environments have no settable attribute `{attr_name}`")

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> list[Any]:
        raise AttributeError(f"CentaurSb3VecEnv: the Rust environments have no method `{method_name}` to call from SB3")

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False] * len(self._get_indices(indices))
