"""Centaur from Python: legged-robot environments with Gymnasium's API, a native vector env,
the rigid-body dynamics and the MPC controller on numpy arrays, and trained policies.

    import gymnasium as gym
    import centaur                                   # registers the centaur/… ids

    env = gym.make("centaur/Minitaur-v0", randomize=False)
    envs = gym.make_vec("centaur/Ant-v5", num_envs=16, vectorization_mode="vector_entry_point")

    model = centaur.Model.for_robot("minitaur")     # or Model.from_urdf(path)
    tau = model.rnea(q, v, a)

Everything runs in Rust (the `centaur._native` extension); this package only adapts it to
Gymnasium, Stable-Baselines3 (`centaur.sb3`) and Ray (`centaur.ray`).
"""

from centaur._native import (
    CentaurError,
    Controller,
    Model,
    Policy,
    __version__,
)
from centaur._registration import ENV_IDS, register_envs
from centaur.envs import CentaurEnv, CentaurVectorEnv

register_envs()

__all__ = [
    "ENV_IDS",
    "CentaurEnv",
    "CentaurError",
    "CentaurVectorEnv",
    "Controller",
    "Model",
    "Policy",
    "__version__",
    "register_envs",
]
