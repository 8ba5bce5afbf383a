"""planetnav: autonomous interplanetary optical navigation as a Gymnasium environment."""

__version__ = "0.1.0"
