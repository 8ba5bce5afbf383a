"""Shared test helpers: pytest reads this file first (fixtures used by several test files go here)."""


def play_episode(agent, env, seed: int) -> dict:
    """Run ``agent`` in ``env`` for one episode seeded ``seed`` (by hand, as an oracle of the evaluation
    harness); return the last step's info."""
    agent.reset(seed=seed)
    obs, info = env.reset(seed=seed)
    done = False
    while not done:
        obs, _, terminated, truncated, info = env.step(agent.act(obs, info))
        done = terminated or truncated
    return info
