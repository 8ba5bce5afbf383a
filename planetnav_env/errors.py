"""Exceptions raised by planetnav.

Every bad input raises one of these (all are ``ValueError`` subclasses, so callers
that only know the standard library still catch them) with the offending value in
the message.
"""

from __future__ import annotations

import numpy as np


class PlanetNavError(ValueError):
    """Base class of every planetnav input error."""


class UnknownBodyError(PlanetNavError, KeyError):
    """A body name that the constants or the ephemeris do not know."""

    def __str__(self) -> str:  # KeyError would quote the message
        return str(self.args[0]) if self.args else ""


class InvalidParameterError(PlanetNavError):
    """A physical parameter out of its valid range (non-positive step, focal length, ...)."""


class NonFiniteError(PlanetNavError):
    """A NaN or infinite value in a state, measurement or action."""


class NotVisibleError(PlanetNavError):
    """A measurement was requested of a body the sensor cannot see."""


class ConfigError(PlanetNavError):
    """An unknown configuration key or an invalid configuration value."""


class OptionError(ConfigError, InvalidParameterError):
    """A declared option (:func:`planetnav_env.options.option`) given a value of the wrong type or out of its
    range. The message names the option (a dotted path inside a section: ``camera.focal_length_mm``), the
    expected type, unit and range, and the value with its type.
    Both a ``ConfigError`` and an ``InvalidParameterError``: the nested settings raised the latter before
    they were declared, the environment options the former."""

    def __init__(self, path: str, expected: str, value: object) -> None:
        self.path, self.expected, self.value = path, expected, value
        super().__init__(f"{path} must be {expected}, got {value!r} ({type(value).__name__})")


class OptionTypeError(OptionError, TypeError):
    """An :class:`OptionError` for a value of the wrong type (also a ``TypeError``, as Python words one)."""


class UnknownOptionError(ConfigError, TypeError):
    """An environment option (keyword argument) that the environment does not have.

    Also a ``TypeError`` worded as Python words an unexpected keyword argument ("got an unexpected keyword
    argument 'frameskip'"): clients probe optional keywords that way (TorchRL's ``GymEnv`` passes
    ``frameskip`` and retries without it only on such a ``TypeError``), so the environment must answer as a
    plain function would.
    """


def require_positive(name: str, value: float) -> float:
    """Return ``float(value)`` or raise :class:`InvalidParameterError` naming it."""
    v = float(value)
    if not np.isfinite(v) or v <= 0.0:
        raise InvalidParameterError(f"{name} must be a positive finite number, got {value!r}")
    return v


def require_finite(name: str, array: np.ndarray) -> np.ndarray:
    """Return ``array`` as float64, or raise :class:`NonFiniteError` naming it and the bad entries."""
    a = np.asarray(array, dtype=float)
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))
        raise NonFiniteError(
            f"{name} contains non-finite values at index {bad[:4].tolist()}"
            f"{' ...' if len(bad) > 4 else ''}: {a[tuple(bad[0])] if a.ndim else a}"
        )
    return a


class DegenerateGeometryError(PlanetNavError):
    """Measurement geometry that does not determine the unknown (one vector, parallel or zero vectors,
    no usable satellites, ...)."""
