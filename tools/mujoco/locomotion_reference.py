"""Random-action statistics of Gymnasium's MuJoCo locomotion envs (v5), for comparison with
Centaur's Rapier versions (`cargo run --release --example env_validation`).

    pip install gymnasium mujoco numpy
    python tools/mujoco/locomotion_reference.py [--episodes 10] [--json]

For each env: mean/std of the return and length over episodes seeded 0..N-1 with uniform
random actions, how episodes ended (torso too low / too high / tilted, per Gymnasium's health
check), the mean forward velocity and the mean torso height.
"""
import argparse
import json

import gymnasium as gym
import numpy as np

ENVS = ["Ant-v5", "Walker2d-v5", "Hopper-v5", "HalfCheetah-v5", "Humanoid-v5"]


def height_and_angle(env_id, qpos):
    if env_id in ("Ant-v5", "Humanoid-v5"):
        return qpos[2], None
    return qpos[1], qpos[2]


def run(env_id, episodes):
    env = gym.make(env_id)
    rets, lens, vels, heights, ends = [], [], [], [], {"truncated": 0, "low": 0, "high": 0, "angle": 0, "other": 0}
    for ep in range(episodes):
        env.reset(seed=ep)
        env.action_space.seed(ep)
        r, n = 0.0, 0
        while True:
            _, rew, term, trunc, info = env.step(env.action_space.sample())
            r += rew
            n += 1
            vels.append(info.get("x_velocity", 0.0))
            qpos = env.unwrapped.data.qpos
            z, angle = height_and_angle(env_id, qpos)
            heights.append(z)
            if term or trunc:
                if trunc:
                    ends["truncated"] += 1
                else:
                    lo, hi = env.unwrapped._healthy_z_range
                    if z <= lo:
                        ends["low"] += 1
                    elif z >= hi:
                        ends["high"] += 1
                    elif angle is not None:
                        ends["angle"] += 1
                    else:
                        ends["other"] += 1
                break
        rets.append(r)
        lens.append(n)
    return {
        "return_mean": float(np.mean(rets)),
        "return_std": float(np.std(rets)),
        "length_mean": float(np.mean(lens)),
        "forward_velocity_mean": float(np.mean(vels)),
        "height_mean": float(np.mean(heights)),
        "ends": ends,
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    out = {e: run(e, args.episodes) for e in ENVS}
    if args.json:
        print(json.dumps(out))
        return
    for e, s in out.items():
        print(f"{e:15s} return {s['return_mean']:9.2f} ± {s['return_std']:7.2f}  length {s['length_mean']:7.1f}  "
              f"v_x {s['forward_velocity_mean']:6.3f}  z {s['height_mean']:5.3f}  ends {s['ends']}")


if __name__ == "__main__":
    main()
