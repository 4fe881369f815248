"""Stable-Baselines3's A2C on Gymnasium's Pendulum-v1 with RL Zoo's tuned settings
(rl-baselines3-zoo, hyperparams/a2c.yml), beside Centaur's A2C on the same settings
(configs/pendulum_a2c_zoo.toml), over seeds: the final deterministic return of each seed.

    pip install stable-baselines3 gymnasium torch
    cargo build --release --bin centaur
    python tools/sb3_a2c_pendulum.py --seeds 3 --steps 300000 [--sde] [--jobs 2]

RL Zoo's settings: 8 environments x 8 steps, gamma 0.9, GAE lambda 0.9, value coefficient
0.4, RMSprop (alpha 0.99, eps 1e-5) at 7e-4 annealed linearly to 0, gradient norm 0.5,
VecNormalize (observations and rewards, the reward's discount 0.9), log_std_init -2 and
no orthogonal initialisation; RL Zoo also explores with gSDE (`--sde`), which Centaur's
A2C does not have. Each seed is evaluated on 10 deterministic episodes with the
observation statistics frozen, as `centaur train` evaluates. Outside CI (torch).
"""
from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def sb3_seed(seed: int, steps: int, sde: bool) -> float:
    import gymnasium as gym
    import numpy as np
    import torch
    from stable_baselines3 import A2C
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecNormalize

    torch.set_num_threads(1)
    env = VecNormalize(make_vec_env("Pendulum-v1", n_envs=8, seed=seed), gamma=0.9)
    model = A2C(
        "MlpPolicy",
        env,
        n_steps=8,
        gamma=0.9,
        gae_lambda=0.9,
        ent_coef=0.0,
        vf_coef=0.4,
        max_grad_norm=0.5,
        learning_rate=lambda progress: 7e-4 * progress,
        use_rms_prop=True,
        normalize_advantage=False,
        use_sde=sde,
        policy_kwargs=dict(log_std_init=-2, ortho_init=False),
        seed=seed,
        device="cpu",
    )
    model.learn(steps)
    env.training = False
    returns = []
    for k in range(10):
        e = gym.make("Pendulum-v1")
        obs, _ = e.reset(seed=1_000_000 + seed + k)
        total, done = 0.0, False
        while not done:
            action, _ = model.predict(env.normalize_obs(obs), deterministic=True)
            obs, r, term, trunc, _ = e.step(action)
            total += float(r)
            done = term or trunc
        returns.append(total)
    return float(np.mean(returns))


def centaur_seed(seed: int, steps: int, exe: str) -> float:
    with tempfile.TemporaryDirectory() as out:
        subprocess.run(
            [exe, "train", "--spec", os.path.join(ROOT, "configs", "pendulum_a2c_zoo.toml"), "--steps", str(steps),
             "--seed", str(seed), "--out", out],
            check=True, capture_output=True, cwd=ROOT,
        )
        with open(os.path.join(out, "summary.json")) as f:
            return float(json.load(f)["final_return_mean"])


def iqm(xs: list[float]) -> float:
    xs = sorted(xs)
    n = len(xs)
    cut = n // 4
    mid = xs[cut:n - cut] if n - 2 * cut > 0 else xs
    return sum(mid) / len(mid)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--steps", type=int, default=300_000)
    ap.add_argument("--sde", action="store_true", help="SB3 with gSDE, as RL Zoo (Centaur has none)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--centaur", default=os.path.join(ROOT, "target", "release", "centaur"), help="the centaur binary")
    args = ap.parse_args()
    seeds = list(range(args.seeds))
    with ProcessPoolExecutor(args.jobs) as pool:
        sb3 = list(pool.map(sb3_seed, seeds, [args.steps] * len(seeds), [args.sde] * len(seeds)))
    ours = [centaur_seed(s, args.steps, args.centaur) for s in seeds]
    print(f"| agent | final return per seed | IQM | worst |")
    print("|---|---|---:|---:|")
    for name, xs in [(f"Stable-Baselines3 A2C{' + gSDE' if args.sde else ''}", sb3), ("Centaur A2C", ours)]:
        print(f"| {name} | {', '.join(f'{x:.0f}' for x in xs)} | {iqm(xs):.0f} | {min(xs):.0f} |")
    print(f"\nPendulum-v1, {args.steps} steps, seeds {seeds}, RL Zoo's A2C settings; load {os.getloadavg()[0]:.2f}",
          file=sys.stderr)


if __name__ == "__main__":
    main()
