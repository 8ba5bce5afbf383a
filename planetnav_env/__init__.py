"""planetnav: autonomous interplanetary optical navigation as a Gymnasium environment.

Importing the package registers the environments (see :mod:`planetnav_env.envs.registration`).
"""

from pathlib import Path as _Path

from planetnav_env.numerics.numba_cache import drop_stale_cache as _drop_stale_cache

__version__ = "0.1.0"

# Before any kernel is declared: compiled kernels cached from an older source would be loaded as they are.
_drop_stale_cache(_Path(__file__).parent, [_Path(__file__).parent])

from planetnav_env.envs.registration import ENV_IDS, register_envs  # noqa: E402

register_envs()

from planetnav_env.envs.parsed_observation import ParsedObservation  # noqa: E402

__all__ = ["ENV_IDS", "ParsedObservation", "__version__"]
