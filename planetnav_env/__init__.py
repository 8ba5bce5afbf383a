"""planetnav: autonomous interplanetary optical navigation as a Gymnasium environment.

Importing the package registers the environments (see :mod:`planetnav_env.registration`).
"""

__version__ = "0.1.0"

from planetnav_env.registration import ENV_IDS, register_envs

register_envs()

__all__ = ["ENV_IDS", "__version__"]
