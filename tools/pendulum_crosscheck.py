#!/usr/bin/env python3
"""Records Gymnasium Pendulum-v1 trajectories as a fixture for centaur-gym's Pendulum.

Usage: /work/venv/py/bin/python tools/pendulum_crosscheck.py [out.json]
(default out: gym/tests/fixtures/pendulum_gymnasium.json). Not run in CI; the Rust test
`pendulum::tests::matches_gymnasium_trajectories` replays the committed fixture: it sets
each episode's initial state, applies the same actions and compares observations and
rewards.

Actions are drawn uniformly from [-3, 3] so that clipping to [-2, 2] is exercised.
"""
import json
import sys

import gymnasium as gym
import numpy as np

out = sys.argv[1] if len(sys.argv) > 1 else "gym/tests/fixtures/pendulum_gymnasium.json"
env = gym.make("Pendulum-v1")
rng = np.random.default_rng(0)
episodes = []
for seed in range(3):
    obs, _ = env.reset(seed=seed)
    th, thdot = env.unwrapped.state
    ep = {"seed": seed, "theta0": float(th), "theta_dot0": float(thdot), "obs0": obs.tolist(),
          "actions": [], "obs": [], "rewards": [], "truncated": []}
    while True:
        a = rng.uniform(-3.0, 3.0, size=(1,)).astype(np.float32)
        obs, r, term, trunc, _ = env.step(a)
        ep["actions"].append(float(a[0]))
        ep["obs"].append([float(x) for x in obs])
        ep["rewards"].append(float(r))
        ep["truncated"].append(bool(trunc))
        assert not term
        if trunc:
            break
    episodes.append(ep)
with open(out, "w") as f:
    json.dump({"source": f"gymnasium {gym.__version__} Pendulum-v1", "episodes": episodes}, f)
print(f"wrote {out}: {len(episodes)} episodes of {len(episodes[0]['actions'])} steps")
