"""The Gymnasium ids of Centaur's environments and their registration."""

from __future__ import annotations

import gymnasium

from centaur import _native

# id -> the name `centaur train --env` takes. Gymnasium's robots keep Gymnasium's version
# (v5: the definitions they follow), the others start at v0.
ENV_IDS: dict[str, str] = {
    "centaur/Pendulum-v1": "pendulum",
    "centaur/Minitaur-v0": "minitaur",
    "centaur/MinitaurFast-v0": "minitaur-fast",
    "centaur/MinitaurDeterministic-v0": "minitaur-deterministic",
    "centaur/Ant-v5": "ant",
    "centaur/Ant27-v5": "ant27",
    "centaur/Walker2d-v5": "walker2d",
    "centaur/Hopper-v5": "hopper",
    "centaur/HalfCheetah-v5": "halfcheetah",
    "centaur/Humanoid-v5": "humanoid",
    "centaur/Gecko-v0": "gecko",
    "centaur/ModularAnt-v0": "modular-ant",
    "centaur/Spider-v0": "spider",
    # The hybrids: the robot's controller in the loop, the action a bounded residual plus
    # the command steering of the robot's residual preset.
    "centaur/Minitaur-Residual-v0": "minitaur-residual",
    "centaur/MinitaurFast-Residual-v0": "minitaur-fast-residual",
    "centaur/MinitaurDeterministic-Residual-v0": "minitaur-deterministic-residual",
    "centaur/Ant-Residual-v5": "ant-residual",
    "centaur/Ant27-Residual-v5": "ant27-residual",
    "centaur/Walker2d-Residual-v5": "walker2d-residual",
    "centaur/Humanoid-Residual-v5": "humanoid-residual",
}

# A modular robot from a body file: gymnasium.make("centaur/Modular-v0", body="robot.json").
MODULAR_ID = "centaur/Modular-v0"


def register_envs() -> None:
    """Registers every id (idempotent; `import centaur` calls it). In a process that has
    not imported centaur, `gymnasium.make("centaur:centaur/Ant-v5")` imports it first.

    Episode length follows Gymnasium: each id's spec carries the preset's length
    (`gymnasium.make(id, max_episode_steps=N)` changes it, `-1` removes it) and
    `gymnasium.make` applies it with its `TimeLimit` wrapper, the environment's own limit
    being lifted; `gymnasium.make_vec` passes it to the Rust environments, which truncate
    themselves. Either way an episode is truncated after exactly that many steps."""
    for env_id, name in [*ENV_IDS.items(), (MODULAR_ID, None)]:
        if env_id in gymnasium.registry:
            continue
        length = None if name is None else _native.Env(name).describe()[3]
        gymnasium.register(
            id=env_id,
            entry_point="centaur.envs:CentaurEnv",
            vector_entry_point="centaur.envs:CentaurVectorEnv",
            max_episode_steps=length,
            kwargs={"name": name, "gymnasium_time_limit": length is not None},
        )
