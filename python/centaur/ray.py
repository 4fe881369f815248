"""Ray, for users who outgrow one machine: Centaur envs in RLlib's env runners, and a
sweep's runs as Ray tasks.

    import ray, centaur.ray
    from ray.rllib.algorithms.ppo import PPOConfig

    ray.init(address="auto")                 # a cluster started with `ray start`
    centaur.ray.register_rllib_envs()        # the centaur/… ids, by name, in every process
    algo = (PPOConfig().environment("centaur/Minitaur-v0", env_config={"randomize": True})
            .env_runners(num_env_runners=8).build_algo())

    table = centaur.ray.sweep("studies/a_ppo_minitaur_lr_arch.toml", seeds=3, out="/shared/runs/a")

Needs `pip install "centaur[ray]"`. On a multi-machine cluster every machine needs this
package installed, and a sweep's grid file and `out` directory must be on storage every
machine sees at the same path (NFS or similar): each task writes its own run directory.
"""

from __future__ import annotations

import os

import gymnasium
import ray
from ray.tune.registry import register_env

from centaur import _native
from centaur._registration import ENV_IDS, register_envs


def _creator(env_id: str):
    def make(env_config):
        register_envs()
        return gymnasium.make(env_id, **dict(env_config or {}))

    return make


def register_rllib_envs() -> None:
    """Registers every `centaur/…` id with Ray's env registry, so that RLlib's env runners
    (other processes, other machines) make it from its name; `env_config` holds the env
    options (the `[env]` keys)."""
    for env_id in ENV_IDS:
        register_env(env_id, _creator(env_id))


@ray.remote(num_cpus=1)
def _run(grid: str, seeds: int, out: str, point: str, seed: int) -> int:
    return _native.sweep_some(grid, seeds, out, [(point, seed)], 1)


def sweep(grid: str | os.PathLike, seeds: int, out: str | os.PathLike) -> str:
    """Runs the sweep of `grid` × `seeds` into `out` with one Ray task per run (one CPU
    each, anywhere in the cluster), then writes the summary as `centaur sweep` does and
    returns its markdown table. Resumable like `centaur sweep`: finished runs are kept."""
    grid, out = os.path.abspath(grid), os.path.abspath(out)
    runs = _native.sweep_run_ids(grid, seeds)
    ray.get([_run.remote(grid, seeds, out, point, seed) for point, seed in runs])
    return _native.sweep(grid, seeds, out, jobs=1)
