"""Exceptions raised by planetnav.

Every bad input raises one of these (all are ``ValueError`` subclasses, so callers
that only know the standard library still catch them) with the offending value in
the message.

Every class here is built from its message alone and pickles. Libraries rebuild an exception that way:
Gymnasium's ``make`` re-raises a ``TypeError`` from the environment's constructor as
``type(e)(f"{e} was raised from the environment creator ...")``, its ``AsyncVectorEnv`` raises a worker's
error as ``type(e)(e)``, and Ray and multiprocessing pickle it. A class whose constructor needs more than
the message would turn a named error into a ``TypeError`` about constructor arguments there.
"""

from __future__ import annotations

import re
from typing import Any

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


#: ``{path} must be {expected}, got ...``: how :class:`OptionError` words its message, read back when an
#: error is rebuilt from the message alone (the path is the last word before "must be", so a prefix such as
#: a file name may stand in front of it).
_OPTION_MESSAGE = re.compile(r"(\S+) must be (.+?), got ", re.DOTALL)


class OptionError(ConfigError, InvalidParameterError):
    """A declared option (:func:`planetnav_env.options.option`) given a value of the wrong type or out of its
    range. The message names the option (a dotted path inside a section: ``camera.focal_length_mm``), the
    expected type, unit and range, and the value with its type.
    Both a ``ConfigError`` and an ``InvalidParameterError``: the nested settings raised the latter before
    they were declared, the environment options the former.

    Built as ``OptionError(path, expected, value)`` (``hint``: a sentence appended to the message), or from
    a message alone as other libraries rebuild exceptions (``type(e)(str(e))``, ``type(e)(e)``; see the
    module's docstring). The fields :attr:`path`, :attr:`expected` and :attr:`value` survive that where
    they can: rebuilt from another ``OptionError`` they are its fields; rebuilt from a message they are
    those of the error it was raised while handling (Gymnasium raises the rebuilt error from the
    original) or, failing that, the path and expected text read from the message, with ``value`` None.
    Pickling keeps them.
    """

    def __init__(
        self, path: str | BaseException, expected: str | None = None, value: object = None, *, hint: str = ""
    ) -> None:
        if expected is None:  # one argument: a message, or an exception whose message this one repeats
            fields = path._fields if isinstance(path, OptionError) else None
            message = str(path)
        else:
            fields = (str(path), expected, value)
            message = f"{path} must be {expected}, got {value!r} ({type(value).__name__})"
            message += f"; {hint}" if hint else ""
        self._fields: tuple[str, str, Any] | None = fields
        super().__init__(message)

    @property
    def path(self) -> str | None:
        """The option's dotted path (``camera.focal_length_mm``); None when the message does not name one."""
        return self._named()[0]

    @property
    def expected(self) -> str | None:
        """What the value must be (``a finite number (float, s) > 0``)."""
        return self._named()[1]

    @property
    def value(self) -> Any:
        """The value given (None when rebuilt from a message whose original error is not at hand)."""
        return self._named()[2]

    def _named(self) -> tuple[str | None, str | None, Any]:
        if self._fields is not None:
            return self._fields
        match = _OPTION_MESSAGE.search(str(self))
        path, expected = (match.group(1), match.group(2)) if match else (None, None)
        # The error this one was rebuilt from, if at hand: Gymnasium 1.4 raises ``from e``
        # (``__cause__``), 1.2 inside the ``except`` block only (``__context__``).
        for linked in (self.__cause__, self.__context__):
            if isinstance(linked, OptionError) and linked is not self and linked.path == path:
                return linked._named()
        return path, expected, None

    def __reduce__(self) -> tuple[Any, ...]:
        # BaseException pickles the message (args) and __dict__; the fields found through the chained
        # original are stored too, since the chain itself does not pickle.
        state = dict(self.__dict__)
        if self._fields is None and (self.__cause__ is not None or self.__context__ is not None):
            path, expected, value = self._named()
            if path is not None:
                state["_fields"] = (path, expected, value)
        return type(self), self.args, state


class OptionTypeError(OptionError, TypeError):
    """An :class:`OptionError` for a value of the wrong type (also a ``TypeError``, as Python words one)."""


class UnknownOptionError(ConfigError, TypeError):
    """An environment option (keyword argument) that the environment does not have.

    Also a ``TypeError`` worded as Python words an unexpected keyword argument ("got an unexpected keyword
    argument 'frameskip'"): clients probe optional keywords that way (TorchRL's ``GymEnv`` passes
    ``frameskip`` and retries without it only on such a ``TypeError``), so the environment must answer as a
    plain function would.
    """


def with_prefix(exc: PlanetNavError, prefix: str) -> PlanetNavError:
    """``exc`` reworded as ``"{prefix}: {exc}"`` (a file name, a section) as an error of the same class, to
    raise in its place. The class is kept, not widened to ``ConfigError``: an :class:`OptionTypeError` read
    from a training YAML is still the ``TypeError`` that ``gym.make`` raises for the same option. An
    :class:`OptionError` keeps its fields."""
    out = type(exc)(f"{prefix}: {exc}")
    if isinstance(exc, OptionError) and isinstance(out, OptionError) and exc.path is not None:
        out._fields = (exc.path, exc.expected, exc.value)
    return out


def require_positive(name: str, value: float) -> float:
    """Return ``float(value)`` or raise :class:`InvalidParameterError` naming it."""
    v = float(value)
    if not np.isfinite(v) or v <= 0.0:
        raise InvalidParameterError(f"{name} must be a positive finite number, got {value!r}")
    return v


def require_count(name: str, value: int, minimum: int = 1) -> int:
    """Return ``int(value)`` for an integer of at least ``minimum`` (bool excluded), or raise
    :class:`InvalidParameterError` naming it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
        what = {0: "a non-negative integer", 1: "a positive integer"}.get(minimum, f"an integer >= {minimum}")
        raise InvalidParameterError(f"{name} must be {what}, got {value!r}")
    return int(value)


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
