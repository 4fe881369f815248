"""Stable-Baselines3's PPO on Centaur's Minitaur through the native vector env, with the
Minitaur settings the Rust examples use (n_steps 1024 per env, batch 512, γ 0.995, lr
2.5e-4), then a deterministic evaluation.

    python python/examples/sb3_minitaur.py [--steps 300000] [--envs 8] [--seed 0] [--save runs/sb3_minitaur]
"""

from __future__ import annotations

import argparse
import time

from stable_baselines3 import PPO
from stable_baselines3.common.evaluation import evaluate_policy
from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

import centaur  # noqa: F401  (registers the ids)
from centaur.sb3 import CentaurSb3VecEnv


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=300_000)
    ap.add_argument("--envs", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--save", help="directory for the SB3 model and the normalisation statistics")
    args = ap.parse_args()

    env = VecNormalize(VecMonitor(CentaurSb3VecEnv("centaur/Minitaur-v0", num_envs=args.envs)), gamma=0.995)
    env.seed(args.seed)
    model = PPO(
        "MlpPolicy", env, n_steps=1024, batch_size=512, gamma=0.995, learning_rate=2.5e-4,
        seed=args.seed, verbose=1,
    )
    start = time.time()
    model.learn(args.steps)
    wall = time.time() - start

    # Deterministic evaluation on fresh episodes, with the training normalisation frozen.
    eval_env = VecNormalize(
        VecMonitor(CentaurSb3VecEnv("centaur/Minitaur-v0", num_envs=1)), training=False, norm_reward=False
    )
    eval_env.obs_rms = env.obs_rms
    eval_env.seed(1_000_000 + args.seed)
    mean, std = evaluate_policy(model, eval_env, n_eval_episodes=args.episodes, deterministic=True)
    print(f"SB3 PPO on centaur/Minitaur-v0, {args.steps} steps, seed {args.seed}: "
          f"{mean:.2f} ± {std:.2f} over {args.episodes} episodes ({wall:.0f} s training, {args.steps / wall:.0f} steps/s)")
    if args.save:
        model.save(f"{args.save}/model")
        env.save(f"{args.save}/vecnormalize.pkl")


if __name__ == "__main__":
    main()
