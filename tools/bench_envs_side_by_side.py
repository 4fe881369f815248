"""Environment throughput, Centaur (Rapier) against PyBullet and MuJoCo, in one run.

    pip install pybullet mujoco gymnasium numpy packaging
    cargo build --release --example bench_envs
    python tools/bench_envs_side_by_side.py [--rounds 3] [--seconds 3]

Rounds alternate the three engines (A/B/C, A/B/C, …) because this machine is shared and
noisy; each figure is the median over rounds, each engine runs on one core:
- Centaur: `bench_envs --json` (one env, uniform random actions, resets included);
- PyBullet: the original MinitaurBulletEnv-v0 (randomiser on, as v0), random actions,
  resets included (its Python env, as users run it);
- MuJoCo: Gymnasium's compiled v5 models stepped raw, `mj_step(model, data, nstep=frame_skip)`
  with random controls (no Python env, no resets: the speed of the engine itself), i.e. the
  "raw control steps/s" of notes/reference-envs.md.
Prints a Markdown table with the ratio Centaur / reference (higher is better).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(HERE, "pybullet"))

MUJOCO = {"ant": ("Ant-v5", 5), "walker2d": ("Walker2d-v5", 4), "hopper": ("Hopper-v5", 4),
          "halfcheetah": ("HalfCheetah-v5", 5), "humanoid": ("Humanoid-v5", 5)}


def centaur(seconds):
    exe = os.path.join(ROOT, "target", "release", "examples", "bench_envs")
    out = subprocess.run([exe, "--json", "--seconds", str(seconds)], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def pybullet_minitaur(seconds):
    import minitaur_reference  # installs the gym shims
    env = minitaur_reference.make(True)
    env.reset()
    rng = np.random.default_rng(0)
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        _, _, done, _ = env.step(rng.uniform(-1, 1, 8))
        steps += 1
        if done:
            env.reset()
    rate = steps / (time.perf_counter() - start)
    env.close()
    return rate


def mujoco_raw(env_id, frame_skip, seconds):
    import gymnasium as gym
    import mujoco
    env = gym.make(env_id)
    env.reset(seed=0)
    m, d = env.unwrapped.model, env.unwrapped.data
    rng = np.random.default_rng(0)
    lo, hi = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
    steps, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        d.ctrl[:] = rng.uniform(lo, hi)
        mujoco.mj_step(m, d, nstep=frame_skip)
        steps += 1
    return steps / (time.perf_counter() - start)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seconds", type=float, default=3.0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    ours, refs = {}, {}
    for _ in range(args.rounds):
        for k, v in centaur(args.seconds).items():
            ours.setdefault(k, []).append(v)
        refs.setdefault("minitaur", []).append(pybullet_minitaur(args.seconds))
        for name, (env_id, skip) in MUJOCO.items():
            refs.setdefault(name, []).append(mujoco_raw(env_id, skip, args.seconds))
    rows = {}
    for name in ["minitaur", "ant", "walker2d", "hopper", "halfcheetah", "humanoid"]:
        o, r = statistics.median(ours[name]), statistics.median(refs[name])
        rows[name] = {"centaur": o, "reference": r, "ratio": o / r,
                      "reference_engine": "PyBullet env" if name == "minitaur" else "MuJoCo raw mj_step"}
    if args.json:
        print(json.dumps(rows))
        return
    print(f"| env | Centaur steps/s | reference steps/s | reference | Centaur / reference |")
    print("|---|---:|---:|---|---:|")
    for name, r in rows.items():
        print(f"| {name} | {r['centaur']:,.0f} | {r['reference']:,.0f} | {r['reference_engine']} | {r['ratio']:.2f}× |")
    print(f"\nmedian of {args.rounds} alternating rounds of {args.seconds} s each; load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
