#!/usr/bin/env python3
"""Training throughput of Stable-Baselines3 on Gymnasium Pendulum-v1, 1 torch thread.

Usage: python tools/sb3_bench.py --algo sac --steps 6000 [--learning-starts 1000] [--seed 0]
Prints one JSON line like `cargo run --release --example bench_rl` (same fields), for the
side-by-side comparison in rl/README.md. Needs `pip install stable-baselines3 torch`.

SB3 defaults throughout (PPO: n_steps 2048, batch 64, 10 epochs, [64, 64]; SAC: batch 256,
[256, 256]; TD3/DDPG: batch 256, [400, 300]; A2C: n_steps 5, RMSprop), with
learning_starts as given for the off-policy learners; one environment wrapped by SB3 in
Monitor + DummyVecEnv.
"""
import argparse
import json
import time

import gymnasium as gym
import torch
from stable_baselines3 import A2C, DDPG, PPO, SAC, TD3

p = argparse.ArgumentParser()
p.add_argument("--algo", default="ppo", choices=["ppo", "a2c", "sac", "td3", "ddpg"])
p.add_argument("--env", default="Pendulum-v1")
p.add_argument("--steps", type=int, default=20480)
p.add_argument("--learning-starts", type=int, default=1000)
p.add_argument("--seed", type=int, default=0)
a = p.parse_args()

torch.set_num_threads(1)
cls = {"ppo": PPO, "a2c": A2C, "sac": SAC, "td3": TD3, "ddpg": DDPG}[a.algo]
off_policy = a.algo in ("sac", "td3", "ddpg")
kwargs = {"learning_starts": a.learning_starts} if off_policy else {}
model = cls("MlpPolicy", gym.make(a.env), seed=a.seed, device="cpu", **kwargs)
t0 = time.perf_counter()
warm = 0.0
if off_policy:
    model.learn(a.learning_starts)
    warm = time.perf_counter() - t0
    model.learn(a.steps - a.learning_starts, reset_num_timesteps=False)
else:
    model.learn(a.steps)
wall = time.perf_counter() - t0
done = model.num_timesteps
after = round((done - a.learning_starts) / (wall - warm), 1) if off_policy else None
print(json.dumps({"impl": "sb3", "algo": a.algo, "env": a.env, "steps": done, "wall": round(wall, 3),
                  "fps": round(done / wall, 1), "fps_after_learning_starts": after}))
