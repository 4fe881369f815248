"""Stable-Baselines3's SAC and PPO learn on Centaur environments through `CentaurSb3VecEnv`
(needs stable-baselines3 and torch: `tools/python_tests.sh`)."""

import numpy as np
import pytest

sb3 = pytest.importorskip("stable_baselines3")
from stable_baselines3.common.env_checker import check_env as sb3_check_env  # noqa: E402
from stable_baselines3.common.evaluation import evaluate_policy  # noqa: E402
from stable_baselines3.common.monitor import Monitor  # noqa: E402

import gymnasium as gym  # noqa: E402

import centaur  # noqa: E402
from centaur.sb3 import CentaurSb3VecEnv  # noqa: E402


def mean_return(model, env_id, episodes=5):
    env = Monitor(gym.make(env_id))
    mean, _ = evaluate_policy(model, env, n_eval_episodes=episodes, deterministic=True)
    return mean


def test_sb3_checker_accepts_the_single_env():
    sb3_check_env(gym.make("centaur/Minitaur-v0").unwrapped, warn=False)


def test_adapter_matches_the_vector_env():
    a = CentaurSb3VecEnv("centaur/Ant-v5", num_envs=2, max_episode_steps=5)
    b = gym.make_vec("centaur/Ant-v5", num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=5)
    a.seed(3)
    np.testing.assert_array_equal(a.reset(), b.reset(seed=3)[0])
    for k in range(5):
        act = np.full((2, 8), 0.1 * k, dtype=np.float32)
        obs, rew, dones, infos = a.step(act)
        o, r, te, tr, info = b.step(act)
        np.testing.assert_array_equal(obs, o)
        np.testing.assert_array_equal(rew, r.astype(np.float32))
        np.testing.assert_array_equal(dones, te | tr)
    assert dones.all() and all(i["TimeLimit.truncated"] for i in infos)
    assert all(i["episode"]["l"] == 5 for i in infos)
    np.testing.assert_array_equal(infos[1]["terminal_observation"], info["final_obs"][1])


def test_sac_learns_the_pendulum():
    env = CentaurSb3VecEnv("centaur/Pendulum-v1", num_envs=1)
    model = sb3.SAC("MlpPolicy", env, learning_starts=500, seed=0, verbose=0)
    before = mean_return(model, "centaur/Pendulum-v1")
    model.learn(6_000)
    after = mean_return(model, "centaur/Pendulum-v1")
    print(f"SAC on centaur/Pendulum-v1, 6k steps: {before:.0f} -> {after:.0f}")
    assert after > -500 and after > before + 400


def test_ppo_learns_the_pendulum():
    env = CentaurSb3VecEnv("centaur/Pendulum-v1", num_envs=4)
    # rl-zoo's Pendulum settings, on a short budget.
    model = sb3.PPO(
        "MlpPolicy", env, n_steps=1024, gae_lambda=0.95, gamma=0.9, n_epochs=10, ent_coef=0.0,
        learning_rate=1e-3, clip_range=0.2, use_sde=True, sde_sample_freq=4, seed=0, verbose=0,
    )
    before = mean_return(model, "centaur/Pendulum-v1")
    model.learn(40_960)
    after = mean_return(model, "centaur/Pendulum-v1")
    print(f"PPO on centaur/Pendulum-v1, 41k steps: {before:.0f} -> {after:.0f}")
    assert after > before + 300
