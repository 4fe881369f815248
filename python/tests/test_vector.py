"""The native vector env: Gymnasium's vector API over the Rust VecEnv, same-step auto-reset,
the same transitions as single environments, independent of the thread count."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import centaur


def make(env_id="centaur/Ant-v5", n=3, **kw):
    return gym.make_vec(env_id, num_envs=n, vectorization_mode="vector_entry_point", **kw)


def test_make_vec_gives_the_native_vector_env():
    envs = make(n=4, num_threads=2)
    assert isinstance(envs, centaur.CentaurVectorEnv)
    assert envs.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    assert envs.observation_space.shape == (4, 105) and envs.observation_space.dtype == np.float32
    assert envs.action_space.shape == (4, 8)
    obs, info = envs.reset(seed=0)
    assert obs.shape == (4, 105) and obs.dtype == np.float32 and info == {}
    obs, rew, term, trunc, info = envs.step(envs.action_space.sample())
    assert rew.shape == (4,) and rew.dtype == np.float64
    assert term.dtype == np.bool_ and trunc.dtype == np.bool_
    assert info["reward_terms"].shape == (4, len(envs.unwrapped.reward_term_names))
    assert info["_forward_velocity"].all()


def test_same_transitions_as_single_envs_with_same_step_autoreset():
    n, seed, horizon = 3, 10, 12
    envs = make(n=n, max_episode_steps=horizon)
    singles = [centaur.CentaurEnv("ant", max_episode_steps=horizon) for _ in range(n)]
    obs, _ = envs.reset(seed=seed)
    for i, e in enumerate(singles):
        np.testing.assert_array_equal(obs[i], e.reset(seed=seed + i)[0])
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(3 * horizon):
        actions = rng.uniform(-1, 1, size=(n, 8)).astype(np.float32)
        obs, rew, term, trunc, info = envs.step(actions)
        for i, e in enumerate(singles):
            o, r, te, tr, _ = e.step(actions[i])
            assert (r, te, tr) == (rew[i], term[i], trunc[i])
            if te or tr:
                ended += 1
                assert info["_final_obs"][i]
                np.testing.assert_array_equal(info["final_obs"][i], o)
                o, _ = e.reset()  # the next episode, from the env's own stream
            np.testing.assert_array_equal(obs[i], o)
    assert ended >= n  # every env finished at least one episode (truncation at 12 steps)


def test_results_do_not_depend_on_threads():
    runs = []
    for threads in (1, 3):
        envs = make("centaur/Minitaur-v0", n=3, num_threads=threads)
        obs, _ = envs.reset(seed=5)
        trace = [obs]
        rng = np.random.default_rng(1)
        for _ in range(30):
            o, r, *_ = envs.step(rng.uniform(-1, 1, size=(3, 8)))
            trace += [o, r]
        runs.append(trace)
    for a, b in zip(*runs):
        np.testing.assert_array_equal(a, b)


def test_seeds_and_bad_calls():
    envs = make(n=3)
    o1, _ = envs.reset(seed=[4, 5, 6])
    o2, _ = envs.reset(seed=4)
    np.testing.assert_array_equal(o1, o2)
    with pytest.raises(centaur.CentaurError, match="consecutive"):
        envs.reset(seed=[4, 9, 2])
    with pytest.raises(centaur.CentaurError, match="shape"):
        envs.step(np.zeros((2, 8)))
    with pytest.raises(centaur.CentaurError, match="NaN"):
        envs.step(np.full((3, 8), np.nan))
    with pytest.raises(centaur.CentaurError, match="at least 1"):
        make(n=0)
    with pytest.raises(centaur.CentaurError):
        make(n=2, num_threads=0)
    envs.reset(seed=0)
    envs.step(np.zeros((3, 8)))
