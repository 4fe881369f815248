"""Steps per second of Centaur's vector env from Python against the Rust VecEnv alone, and
Gymnasium's own MuJoCo vector envs beside them, in one run.

    python python/bench/throughput.py [--envs 16] [--threads N] [--steps 300] [--repeats 3]

For each robot: the Rust `VecEnv` stepping random actions with no Python in the loop
(`centaur._native.bench_vec_env`), the same envs on the same threads with the same actions
and seed (so the same episodes) driven from Python through `gymnasium.make_vec(..., vectorization_mode="vector_entry_point")`, and where
`mujoco` is installed Gymnasium's MuJoCo robot of the same name in its "sync" (one
process, a Python loop over the envs) and "async" (one process per env) vector envs.
Each figure is the median of `--repeats` runs, the variants alternating; the ratio column
is Python over Rust. Prints a markdown table.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time

import gymnasium as gym
import numpy as np

import centaur
from centaur import _native

ROBOTS = [("Ant", "ant", "centaur/Ant-v5", "Ant-v5"), ("Humanoid", "humanoid", "centaur/Humanoid-v5", "Humanoid-v5"),
          ("Minitaur", "minitaur", "centaur/Minitaur-v0", None)]


def random_actions(envs, steps, seed):
    rng = np.random.default_rng(seed)
    lo, hi = envs.action_space.low, envs.action_space.high
    return rng.uniform(lo, hi, size=(steps, *envs.action_space.shape)).astype(envs.action_space.dtype)


def python_rate(envs, actions, seed=0):
    steps = len(actions)
    envs.reset(seed=seed)
    start = time.perf_counter()
    for a in actions:
        envs.step(a)
    return envs.num_envs * steps / (time.perf_counter() - start)


def cpu_name() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--envs", type=int, default=16)
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--steps", type=int, default=300, help="batch steps per measurement")
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-mujoco", action="store_true")
    args = ap.parse_args()
    try:
        import mujoco  # noqa: F401

        have_mujoco = not args.no_mujoco
    except ImportError:
        have_mujoco = False

    print(f"{args.envs} envs, {args.threads} threads, {args.steps} batch steps × {args.repeats} repeats; "
          f"{cpu_name()}, {os.cpu_count()} logical CPUs; centaur {centaur.__version__}")
    print()
    print("| robot | Rust VecEnv (steps/s) | Python, native vector env | Python / Rust | Gymnasium MuJoCo sync | Gymnasium MuJoCo async |")
    print("|---|---|---|---|---|---|")
    for label, name, env_id, mujoco_id in ROBOTS:
        rust, py, sync, asyn = [], [], [], []
        native = gym.make_vec(env_id, num_envs=args.envs, vectorization_mode="vector_entry_point",
                              num_threads=args.threads)
        mj = {}
        if have_mujoco and mujoco_id:
            mj["sync"] = gym.make_vec(mujoco_id, num_envs=args.envs, vectorization_mode="sync")
            mj["async"] = gym.make_vec(mujoco_id, num_envs=args.envs, vectorization_mode="async")
        for r in range(args.repeats):
            # The same actions and seed for Rust and Python: the same episodes.
            actions = random_actions(native, args.steps, seed=r)
            rust.append(_native.bench_vec_env(name, args.envs, args.threads, actions, seed=r))
            py.append(python_rate(native, actions, seed=r))
            if mj:
                mj_actions = random_actions(mj["sync"], args.steps, seed=r)
                sync.append(python_rate(mj["sync"], mj_actions, seed=r))
                asyn.append(python_rate(mj["async"], mj_actions, seed=r))
        for e in mj.values():
            e.close()
        med = statistics.median
        fmt = lambda xs: f"{med(xs):,.0f}" if xs else "—"  # noqa: E731
        print(f"| {label} | {fmt(rust)} | {fmt(py)} | {med(py) / med(rust):.3f} | {fmt(sync)} | {fmt(asyn)} |", flush=True)


if __name__ == "__main__":
    main()
