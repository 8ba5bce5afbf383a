"""Gymnasium registration of the planetnav environments (namespace ``planetnav``).

``import planetnav_env`` registers them; ``gymnasium.make("planetnav/Cruise-Target-v0")`` then works.
Without the import, ``gymnasium.make("planetnav_env:planetnav/Cruise-Target-v0")`` imports it first.
"""

from __future__ import annotations

import gymnasium as gym

ENV_IDS: dict[str, dict] = {
    "planetnav/Cruise-Target-v0": {"scenario": "cruise", "action_mode": "target"},
    "planetnav/Cruise-Torque-v0": {"scenario": "cruise", "action_mode": "torque"},
    "planetnav/Cruise-TargetTorque-v0": {"scenario": "cruise", "action_mode": "target+torque"},
    "planetnav/RandomCruise-Target-v0": {"scenario": "random-cruise", "action_mode": "target"},
    # Sensor tasking on Mars approach (patent 003): image Mars or time one of two X-ray pulsars.
    # 94 h at 300 s steps ending 2 h before closest approach; filter settings of docs/optical_pulsar.md.
    "planetnav/MarsApproach-Tasking-v0": {
        "scenario": "mars-approach",
        "action_mode": "target",
        "planets": ("mars",),
        "pulsars": ("B0531+21", "B1937+21"),
        "step_s": 300.0,
        "episode_steps": 1128,
        "reward_scale_km": 10.0,
        "filter": {"sigma_pos0": 100.0, "sigma_vel0": 1e-3, "accel_psd": 1e-16},
    },
}


def register_envs() -> None:
    for env_id, kwargs in ENV_IDS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point="planetnav_env.env:PlanetNavEnv",
            # gym.make_vec(id, num_envs=N) builds the native vector env over the batch core (the id's
            # kwargs are passed to it); vectorization_mode="sync" still gives a SyncVectorEnv.
            vector_entry_point="planetnav_env.vector_env:PlanetNavVectorEnv",
            kwargs=dict(kwargs),
            disable_env_checker=True,  # the env validates its own actions; check_env runs in the tests
        )
