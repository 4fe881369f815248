"""A CleanRL-style torch PPO loop learns on the native vector env (needs torch:
`tools/python_tests.sh`)."""

import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "cleanrl_style_ppo.py"


def test_cleanrl_style_ppo_learns_the_pendulum():
    spec = importlib.util.spec_from_file_location("cleanrl_style_ppo", EXAMPLE)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    history = example.train("centaur/Pendulum-v1", total_steps=81_920, num_envs=8, seed=0, log=lambda _: None)
    first, last = np.mean(history[:3]), np.mean(history[-3:])
    print(f"CleanRL-style PPO on centaur/Pendulum-v1, 82k steps: {first:.0f} -> {last:.0f}")
    assert last > -600 and last > first + 400
