"""A single-file PPO in the style of CleanRL (torch, one loop you can read top to bottom) on
Centaur's native vector env: `gymnasium.make_vec(..., vectorization_mode="vector_entry_point")`
steps the batch in Rust threads; same-step auto-reset means the observation after a done is
the next episode's first, and `infos["final_obs"]` holds the last one for bootstrapping a
truncated episode.

    python python/examples/cleanrl_style_ppo.py [--env centaur/Pendulum-v1] [--steps 100000] [--envs 8]
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np
import torch
from torch import nn

import centaur  # noqa: F401  (registers the ids)


def layer(n_in, n_out, gain=np.sqrt(2)):
    lin = nn.Linear(n_in, n_out)
    nn.init.orthogonal_(lin.weight, gain)
    nn.init.zeros_(lin.bias)
    return lin


class Agent(nn.Module):
    def __init__(self, obs_dim, act_dim):
        super().__init__()
        self.critic = nn.Sequential(layer(obs_dim, 64), nn.Tanh(), layer(64, 64), nn.Tanh(), layer(64, 1, 1.0))
        self.actor = nn.Sequential(layer(obs_dim, 64), nn.Tanh(), layer(64, 64), nn.Tanh(), layer(64, act_dim, 0.01))
        self.log_std = nn.Parameter(torch.zeros(act_dim))

    def dist(self, obs):
        return torch.distributions.Normal(self.actor(obs), self.log_std.exp())


def train(env_id="centaur/Pendulum-v1", total_steps=100_000, num_envs=8, n_steps=256, epochs=10, minibatches=8,
          lr=1e-3, gamma=0.9, lam=0.95, clip=0.2, seed=0, log=print):
    """PPO with GAE, clipped objective, advantage normalisation; returns the mean return of
    the episodes finished in each iteration."""
    torch.manual_seed(seed)
    envs = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point")
    obs_dim, act_dim = envs.single_observation_space.shape[0], envs.single_action_space.shape[0]
    low, high = envs.single_action_space.low, envs.single_action_space.high
    agent = Agent(obs_dim, act_dim)
    opt = torch.optim.Adam(agent.parameters(), lr=lr, eps=1e-5)
    obs_buf = torch.zeros(n_steps, num_envs, obs_dim)
    act_buf = torch.zeros(n_steps, num_envs, act_dim)
    logp_buf, rew_buf, done_buf, val_buf = (torch.zeros(n_steps, num_envs) for _ in range(4))
    obs, _ = envs.reset(seed=seed)
    obs = torch.as_tensor(obs)
    history = []
    for _ in range(total_steps // (n_steps * num_envs)):
        returns = []
        for t in range(n_steps):
            with torch.no_grad():
                d = agent.dist(obs)
                action = d.sample()
                obs_buf[t], act_buf[t], logp_buf[t] = obs, action, d.log_prob(action).sum(-1)
                val_buf[t] = agent.critic(obs).squeeze(-1)
            next_obs, reward, terminated, truncated, infos = envs.step(np.clip(action.numpy(), low, high))
            reward = torch.as_tensor(reward, dtype=torch.float32)
            if "final_obs" in infos:  # bootstrap truncated episodes from their last observation
                for i in np.flatnonzero(truncated & ~terminated):
                    with torch.no_grad():
                        reward[i] += gamma * agent.critic(torch.as_tensor(infos["final_obs"][i])).item()
                returns += list(infos["episode"]["r"][infos["_episode"]])
            rew_buf[t], done_buf[t] = reward, torch.as_tensor(terminated | truncated, dtype=torch.float32)
            obs = torch.as_tensor(next_obs)
        with torch.no_grad():  # GAE(λ)
            adv = torch.zeros_like(rew_buf)
            next_val, gae = agent.critic(obs).squeeze(-1), 0.0
            for t in reversed(range(n_steps)):
                nonterminal = 1.0 - done_buf[t]
                delta = rew_buf[t] + gamma * next_val * nonterminal - val_buf[t]
                gae = delta + gamma * lam * nonterminal * gae
                adv[t], next_val = gae, val_buf[t]
            ret = adv + val_buf
        b_obs, b_act = obs_buf.reshape(-1, obs_dim), act_buf.reshape(-1, act_dim)
        b_logp, b_adv, b_ret = logp_buf.reshape(-1), adv.reshape(-1), ret.reshape(-1)
        batch = b_obs.shape[0]
        for _ in range(epochs):
            for mb in torch.randperm(batch).split(batch // minibatches):
                d = agent.dist(b_obs[mb])
                ratio = (d.log_prob(b_act[mb]).sum(-1) - b_logp[mb]).exp()
                a = (b_adv[mb] - b_adv[mb].mean()) / (b_adv[mb].std() + 1e-8)
                pg_loss = torch.max(-a * ratio, -a * ratio.clamp(1 - clip, 1 + clip)).mean()
                v_loss = 0.5 * (agent.critic(b_obs[mb]).squeeze(-1) - b_ret[mb]).pow(2).mean()
                opt.zero_grad()
                (pg_loss + 0.5 * v_loss).backward()
                nn.utils.clip_grad_norm_(agent.parameters(), 0.5)
                opt.step()
        history.append(float(np.mean(returns)) if returns else float("nan"))
        log(f"iteration {len(history)}: mean episode return {history[-1]:.1f}")
    envs.close()
    return history


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--env", default="centaur/Pendulum-v1")
    ap.add_argument("--steps", type=int, default=100_000)
    ap.add_argument("--envs", type=int, default=8)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    start = time.time()
    history = train(args.env, args.steps, args.envs, seed=args.seed)
    print(f"{args.env}: {args.steps} steps in {time.time() - start:.0f} s, last return {history[-1]:.1f}")


if __name__ == "__main__":
    main()
