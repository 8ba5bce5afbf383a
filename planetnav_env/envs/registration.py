"""Gymnasium registration of the planetnav environments (namespace ``planetnav``), read from the task
declarations of :mod:`planetnav_env.tasks`.

``import planetnav_env`` registers them; ``gymnasium.make("planetnav/Cruise-Target-v0")`` then works.
Without the import, ``gymnasium.make("planetnav_env:planetnav/Cruise-Target-v0")`` imports it first.

``max_episode_steps``: an environment built by ``gym.make`` or ``gym.make_vec`` reports its own
``episode_steps`` as ``env.spec.max_episode_steps`` (1,440 for the cruise ids, 1,128 for the Mars
approach, or whatever ``episode_steps`` the caller passed). The registry's spec leaves it ``None`` on
purpose: a value there makes ``gym.make`` add Gymnasium's ``TimeLimit`` wrapper, a second counter that
truncates at the registered length even when the caller asked for a longer episode.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from planetnav_env.errors import ConfigError
from planetnav_env.tasks import ID_OPTIONS

#: The single environment's entry point (a spec with another one is not a planetnav environment).
ENTRY_POINT = "planetnav_env.envs.env:PlanetNavEnv"

#: Every registered id's options (``gym.make(id)`` passes them), from the task declarations
#: (:mod:`planetnav_env.tasks`): all ``-v0`` ids, then ``-v1``, then ``-v2``.
ENV_IDS: dict[str, dict[str, Any]] = ID_OPTIONS


def id_options(env_id: str) -> dict[str, Any]:
    """The environment options that the registered id ``env_id`` stands for (a copy of its spec's
    ``config`` kwarg), as ``gym.make(env_id)`` passes them; ``"module:id"`` is accepted as ``gym.make``
    accepts it.

    Raises :class:`~planetnav_env.errors.ConfigError` naming the id when it is not registered or is not a
    planetnav environment.
    """
    name = env_id.split(":", 1)[1] if ":" in env_id else env_id
    try:
        spec = gym.spec(name)
    except gym.error.Error:
        raise ConfigError(
            f"unknown environment id {env_id!r}; the planetnav ids are {sorted(ENV_IDS)}"
        ) from None
    entry = spec.entry_point
    entry_name = entry if isinstance(entry, str) else f"{entry.__module__}:{entry.__qualname__}"
    if entry_name != ENTRY_POINT:
        raise ConfigError(
            f"{env_id!r} is not a planetnav environment (entry point {entry_name!r}); "
            f"the planetnav ids are {sorted(ENV_IDS)}"
        )
    return dict(spec.kwargs["config"])


def register_envs() -> None:
    """Register every declared version (:data:`planetnav_env.tasks.VERSIONS`) with its options
    (:data:`ENV_IDS`); ids already registered are left as they are."""
    for env_id, kwargs in ENV_IDS.items():
        if env_id in gym.registry:
            continue
        gym.register(
            id=env_id,
            entry_point=ENTRY_POINT,
            # gym.make_vec(id, num_envs=N) builds the native vector env over the batch core (the id's
            # kwargs are passed to it); vectorization_mode="sync" still gives a SyncVectorEnv.
            vector_entry_point="planetnav_env.envs.vector_env:PlanetNavVectorEnv",
            # The options travel as one ``config`` mapping, not flattened: gym.make updates the spec's
            # kwargs shallowly, so a flattened ``world`` would be replaced whole by a caller's partial
            # ``world={...}`` (the task's preset silently lost); as keyword overrides of ``config`` the
            # env merges them into the id's options (``EnvConfig.from_dict``).
            kwargs={"config": dict(kwargs)},
            disable_env_checker=True,  # the env validates its own actions; check_env runs in the tests
        )
