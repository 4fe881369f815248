"""Runs PyBullet's original MinitaurBulletEnv-v0 (pybullet_envs/bullet, unmodified) on the
same action streams as Centaur's `minitaur_validation` example, and prints the same table.

    pip install pybullet gymnasium numpy packaging
    python tools/pybullet/minitaur_reference.py [--json]

`pybullet_envs` imports the old `gym` package and `pkg_resources`; this script aliases them
to gymnasium (Env, spaces, seeding only) and `packaging.version` before importing it. The
physics, motor model, reward and termination are PyBullet's own code. Randomisation is
switched off where the comparison must be deterministic (as in Centaur's deterministic
config) and on for the random-action statistics (as v0 defines it).
"""
import argparse
import json
import math
import sys
import types

import gymnasium
import numpy as np
from packaging.version import parse as parse_version


def install_shims():
    gym = types.ModuleType("gym")
    gym.__path__ = []  # a package, so that submodules resolve
    gym.Env = gymnasium.Env
    gym.spaces = gymnasium.spaces
    gym.__version__ = "0.21.0"
    # pybullet_envs/__init__.py registers its envs with gym's registry: give it a stub.
    envs = types.ModuleType("gym.envs")
    registration = types.ModuleType("gym.envs.registration")
    registration.registry = types.SimpleNamespace(env_specs={})
    registration.register = lambda *a, **k: None
    registration.make = registration.spec = None
    envs.registration = registration
    gym.envs = envs
    sys.modules["gym.envs"] = envs
    sys.modules["gym.envs.registration"] = registration
    utils = types.ModuleType("gym.utils")
    utils.seeding = gymnasium.utils.seeding
    gym.utils = utils
    sys.modules["gym"] = gym
    sys.modules["gym.spaces"] = gymnasium.spaces
    sys.modules["gym.utils"] = utils
    sys.modules["gym.utils.seeding"] = gymnasium.utils.seeding
    pkg = types.ModuleType("pkg_resources")
    pkg.parse_version = parse_version
    sys.modules["pkg_resources"] = pkg


install_shims()
from pybullet_envs.bullet.minitaur_gym_env import MinitaurBulletEnv  # noqa: E402


def make(randomize):
    if randomize:
        return MinitaurBulletEnv()
    return MinitaurBulletEnv(env_randomizer=None)


def trot_action(t, sign):
    # a[0:4] = 0.35 cos(4πt + φ): diagonal legs (front_left/back_right, back_left/front_right) in phase.
    a = np.zeros(8)
    for leg in range(4):
        phase = 0.0 if leg in (0, 3) else math.pi
        a[leg] = sign * 0.35 * math.cos(4 * math.pi * t + phase)
    return a


def lift_trot_action(t):
    # Trot that also shortens the swinging legs: a[leg] = 0.3 cos(4πt + φ), a[4 + leg] = 0.3 sin(4πt + φ).
    a = np.zeros(8)
    for leg in range(4):
        phase = 0.0 if leg in (0, 3) else math.pi
        a[leg] = 0.3 * math.cos(4 * math.pi * t + phase)
        a[4 + leg] = 0.3 * math.sin(4 * math.pi * t + phase)
    return a


def run_open_loop(env, policy, steps):
    env.reset()
    energy = 0.0
    for k in range(steps):
        _, _, done, _ = env.step(policy(k * 0.01))
        m = env.minitaur
        # Applied torque (joint frame) times joint velocity, summed per physics step is what
        # Centaur reports; PyBullet does not expose it per substep, so use the last substep.
        tau = np.asarray(m._applied_motor_torque) if hasattr(m, "_applied_motor_torque") else np.zeros(8)
        qd = np.multiply(m.GetMotorVelocities(), m._motor_direction)
        energy += abs(float(np.dot(tau, qd))) * env._time_step * env._action_repeat
        if done:
            return k + 1, energy
    return steps, energy


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    out = {}
    env = make(False)
    env.reset()
    out["reset_base_z"] = env.minitaur.GetBasePosition()[2]
    run_open_loop(env, lambda t: np.zeros(8), 500)
    out["stand_zero_action_z_5s"] = env.minitaur.GetBasePosition()[2]
    for sign in (1.0, -1.0):
        n, e = run_open_loop(env, lambda t: trot_action(t, sign), 1000)
        out[f"trot_{'+' if sign > 0 else '-'}_x_10s"] = env.minitaur.GetBasePosition()[0]
        out[f"trot_{'+' if sign > 0 else '-'}_steps"] = n
        out[f"trot_{'+' if sign > 0 else '-'}_energy_J"] = e
    n, e = run_open_loop(env, lift_trot_action, 1000)
    out["lift_trot_x_10s"] = env.minitaur.GetBasePosition()[0]
    out["lift_trot_y_10s"] = env.minitaur.GetBasePosition()[1]
    out["lift_trot_steps"] = n
    out["lift_trot_energy_J"] = e
    env.close()
    env = make(True)
    rets, lens, falls = [], [], 0
    for ep in range(10):
        np.random.seed(ep)
        import random
        random.seed(ep)
        env.reset()
        rng = np.random.default_rng(ep)
        r, n = 0.0, 0
        while True:
            _, rew, done, _ = env.step(rng.uniform(-1, 1, 8))
            r += rew
            n += 1
            if done or n >= 1000:
                falls += int(done)
                break
        rets.append(r)
        lens.append(n)
    out["random_return_mean"] = float(np.mean(rets))
    out["random_return_std"] = float(np.std(rets))
    out["random_length_mean"] = float(np.mean(lens))
    out["random_falls"] = falls
    if args.json:
        print(json.dumps(out))
    else:
        for k, v in out.items():
            print(f"{k:28s} {v:.4f}" if isinstance(v, float) else f"{k:28s} {v}")


if __name__ == "__main__":
    main()
