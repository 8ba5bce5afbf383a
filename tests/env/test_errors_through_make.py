"""Bad options reach the user as planetnav's named errors through every way of making an environment, and
every planetnav exception survives what other libraries do with it.

Gymnasium's ``make`` re-raises a ``TypeError`` from the environment's constructor as
``type(e)(f"{e} was raised from the environment creator ...")`` and its ``AsyncVectorEnv`` raises a worker's
error as ``type(e)(e)``; Ray and multiprocessing pickle exceptions. Each bad-option case of
``test_config_options.py`` (a wrong type, below and above the range, a length off, for every declared
option) and a few written here run through ``gym.make``, ``gym.make_vec`` (native, sync, async),
``PlanetNavEnv``, ``PlanetNavVectorEnv``, ``EnvConfig.from_yaml`` and a training YAML. The errors fire while
the configuration is read, before anything is compiled or reset, so the cases cost milliseconds each.
"""

from __future__ import annotations

import ast
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym
import pytest
import yaml
from test_config_options import CASES as OPTION_CASES

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env import errors
from planetnav_env.config import EnvConfig
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import (
    ConfigError,
    OptionError,
    OptionTypeError,
    PlanetNavError,
    UnknownOptionError,
)
from planetnav_env.sensors.pulsar import UnknownPulsarError

ROOT = Path(__file__).resolve().parents[2]
ENV_ID = "planetnav/Cruise-Target-v1"

#: The mistakes users make most, beside the declarations' own cases: a number or a count given as text
#: or as a fraction, and one name where a list of names is expected.
EXTRA_CASES = [
    pytest.param("step_s", "60", OptionTypeError, id="step_s-text"),
    pytest.param("episode_steps", 2.5, OptionTypeError, id="episode_steps-fraction"),
    pytest.param("planets", "venus", OptionTypeError, id="planets-one-name"),
    pytest.param("pulsars", "B0531+21", OptionTypeError, id="pulsars-one-name"),
    pytest.param("operations.deadlines_s", 604800.0, OptionTypeError, id="operations.deadlines_s-one-number"),
    pytest.param("camera.focal_length_mm", -1, OptionError, id="camera.focal_length_mm-negative"),
]
CASES = [*OPTION_CASES, *EXTRA_CASES]


def _kwargs(path: str, value: Any) -> dict[str, Any]:
    """The options that put ``value`` at the dotted ``path`` (a section's options as a mapping), as
    ``test_config_options._config`` passes them (operations need target actions and the idle action)."""
    head, _, leaf = path.rpartition(".")
    if not head:
        return {path: value}
    extra = {"action_mode": "target", "idle_action": True} if head == "operations" else {}
    return {head: {leaf: value}, **extra}


def _write_yaml(tmp_path: Path, data: dict[str, Any]) -> Path:
    path = tmp_path / "config.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


def _train_config(kw: dict[str, Any], tmp_path: Path) -> Any:
    """``train.py train --config X.yaml``'s reading of its file (``planetnav_train.config.load_config``)."""
    pytest.importorskip("stable_baselines3", reason="planetnav_train needs the [train] extra")
    from planetnav_train.config import load_config

    return load_config(_write_yaml(tmp_path, {"algo": "ppo", "env_id": ENV_ID, "env": kw}))


#: Each way a user makes an environment (or reads its options), as ``entry(options, tmp_path)``.
ENTRIES: dict[str, Callable[[dict[str, Any], Path], Any]] = {
    "gym.make": lambda kw, _: gym.make(ENV_ID, **kw),
    "make_vec-native": lambda kw, _: gym.make_vec(
        ENV_ID, num_envs=2, vectorization_mode="vector_entry_point", **kw
    ),
    "make_vec-sync": lambda kw, _: gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="sync", **kw),
    "PlanetNavEnv": lambda kw, _: PlanetNavEnv(**kw),
    "PlanetNavVectorEnv": lambda kw, _: PlanetNavVectorEnv(2, **kw),
    "EnvConfig.from_yaml": lambda kw, tmp: EnvConfig.from_yaml(_write_yaml(tmp, {"env": kw})),
    "train-config": _train_config,
}


def _make_async(kw: dict[str, Any], _: Path) -> Any:
    return gym.make_vec(ENV_ID, num_envs=2, vectorization_mode="async", **kw)


def _raised(
    entry: Callable[[dict[str, Any], Path], Any], kw: dict[str, Any], tmp_path: Path
) -> BaseException:
    """The exception ``entry`` raises for the options ``kw`` (the test fails if it builds an environment)."""
    with pytest.raises(Exception) as info:  # any class: the caller checks which
        made = entry(kw, tmp_path)
        if hasattr(made, "close"):
            made.close()
    return info.value


def _check_option_error(exc: BaseException, path: str, value: Any, err: type) -> None:
    """``exc`` is planetnav's ``err`` (exactly), the builtin base it promises, names ``path`` and what it
    must be, and shows ``value``; its fields hold them too."""
    assert type(exc) is err, f"{type(exc).__module__}.{type(exc).__name__}: {exc}"
    assert type(exc).__module__ == "planetnav_env.errors"
    assert isinstance(exc, ValueError)  # every planetnav input error
    assert isinstance(exc, TypeError) == (err is OptionTypeError), exc  # a wrong type, and only that
    msg = str(exc)
    assert exc.path == path and exc.expected, (exc.path, exc.expected, msg)
    assert f"{path} must be {exc.expected}, got {value!r} ({type(value).__name__})" in msg, msg
    assert repr(exc.value) == repr(value), (exc.value, value)  # repr: NaN equals NaN, a list its YAML copy


@pytest.mark.parametrize("entry", sorted(ENTRIES))
@pytest.mark.parametrize("path,value,err", CASES)
def test_bad_option_is_named_through_each_entry_point(
    entry: str, path: str, value: Any, err: type, tmp_path: Path
) -> None:
    exc = _raised(ENTRIES[entry], _kwargs(path, value), tmp_path)
    _check_option_error(exc, path, value, err)


@pytest.mark.parametrize("entry", sorted(ENTRIES))
def test_unknown_option_is_named_through_each_entry_point(entry: str, tmp_path: Path) -> None:
    """Still a ``TypeError`` worded as Python's (clients probe keywords that way) and a ConfigError."""
    exc = _raised(ENTRIES[entry], {"frameskip": 4}, tmp_path)
    assert type(exc) is UnknownOptionError, f"{type(exc).__name__}: {exc}"
    assert isinstance(exc, TypeError) and isinstance(exc, ConfigError)
    assert "got an unexpected keyword argument 'frameskip'" in str(exc), str(exc)


#: Gymnasium's AsyncVectorEnv starts a process per environment; a few cases keep it cheap. It builds one
#: environment in this process first (for the spaces), and that one raises the option error, through
#: gym.make's re-raise, before any process starts.
ASYNC_CASES = [
    c for c in EXTRA_CASES if c.id in ("step_s-text", "planets-one-name", "camera.focal_length_mm-negative")
]


@pytest.mark.parametrize("path,value,err", ASYNC_CASES)
def test_bad_option_is_named_through_make_vec_async(path: str, value: Any, err: type, tmp_path: Path) -> None:
    _check_option_error(_raised(_make_async, _kwargs(path, value), tmp_path), path, value, err)


def test_unknown_option_is_named_through_make_vec_async(tmp_path: Path) -> None:
    exc = _raised(_make_async, {"frameskip": 4}, tmp_path)
    assert type(exc) is UnknownOptionError and "unexpected keyword argument 'frameskip'" in str(exc), exc


def test_gym_make_keeps_planetnavs_message_in_front() -> None:
    """The message the user reads first is planetnav's; Gymnasium's note on the id follows it."""
    with pytest.raises(OptionTypeError) as info:
        gym.make(ENV_ID, step_s="60")
    msg = str(info.value)
    assert msg.startswith("step_s must be a finite number (float, s) > 0, got '60' (str)"), msg
    assert ENV_ID in msg, msg  # Gymnasium's part names the id
    assert info.value.value == "60"


@pytest.mark.parametrize(
    "path,value,hint",
    [
        ("planets", "venus", "for a single name write a one-element list: ['venus']"),
        ("pulsars", "B0531+21", "for a single name write a one-element list: ['B0531+21']"),
        ("operations.deadlines_s", 604800, "for a single number write a one-element list: [604800.0]"),
    ],
)
def test_one_item_where_a_list_is_expected_says_to_write_a_list_of_one(
    path: str, value: Any, hint: str
) -> None:
    with pytest.raises(OptionTypeError) as info:
        EnvConfig.from_dict(_kwargs(path, value))
    assert str(info.value).endswith(f"; {hint}"), str(info.value)
    assert info.value.path == path


def test_a_list_of_one_is_what_to_write() -> None:
    cfg = EnvConfig.from_dict({"planets": ["venus"], "pulsars": ["B0531+21"]})
    assert cfg.planets == ("venus",) and cfg.pulsars == ("B0531+21",)


def test_one_item_of_the_wrong_type_or_where_a_list_of_one_is_too_short_gets_no_hint() -> None:
    """No "write [x]" where ``[x]`` would be refused too: an item of the wrong type, a fixed length > 1."""
    for kw in ({"planets": 5}, {"star_tracker_bias_arcsec": 1.0}, {"camera": {"resolution_px": 1024}}):
        with pytest.raises(OptionTypeError) as info:
            EnvConfig.from_dict(kw)
        assert "one-element list" not in str(info.value), str(info.value)


# --- each exception class, rebuilt and pickled -------------------------------------------------------------
PACKAGES = ("planetnav_env", "agents", "planetnav_train", "planetnav_rl")


def _exception_classes() -> list[type[BaseException]]:
    """Every exception class the planetnav packages define (those in planetnav_train and planetnav_rl, if
    any, would join here; today they define none)."""
    from planetnav_agents.base import NotApplicableError
    from planetnav_env.device.preflight import CheckFailed, Skipped

    own = [c for c in vars(errors).values() if isinstance(c, type) and issubclass(c, BaseException)]
    return [*own, UnknownPulsarError, NotApplicableError, CheckFailed, Skipped]


def _defined_exception_names() -> set[str]:
    """Names of the classes defined in the packages' sources whose bases read as exceptions."""
    names: set[str] = set()
    for package in PACKAGES:
        for source in (ROOT / package).rglob("*.py"):
            for node in ast.walk(ast.parse(source.read_text(), str(source))):
                if isinstance(node, ast.ClassDef) and any(
                    ast.unparse(b).split(".")[-1].endswith(("Error", "Exception")) for b in node.bases
                ):
                    names.add(node.name)
    return names


def test_every_exception_class_is_checked() -> None:
    assert {c.__name__ for c in _exception_classes()} == _defined_exception_names()


def _instance(cls: type[BaseException]) -> BaseException:
    if issubclass(cls, OptionError):
        return cls("camera.focal_length_mm", "a finite number (float, mm) > 0", -1)
    return cls("bad input 'x': a message with quotes and a colon")


@pytest.mark.parametrize("cls", _exception_classes(), ids=lambda c: c.__name__)
def test_exception_rebuilds_from_its_message_and_pickles(cls: type[BaseException]) -> None:
    exc = _instance(cls)
    for again in (
        cls(str(exc)),  # type(e)(str(e)): how libraries re-raise with more words
        cls(exc),  # type(e)(e): AsyncVectorEnv raising a worker's error
        pickle.loads(pickle.dumps(exc)),  # Ray, multiprocessing
        pickle.loads(pickle.dumps(cls(exc))),
    ):
        assert type(again) is cls and str(again) == str(exc), (type(again), str(again), str(exc))
    said = cls(f"{exc} was raised from the environment creator for {ENV_ID} with kwargs (...)")
    assert type(said) is cls and str(said).startswith(str(exc))
    if issubclass(cls, OptionError):
        for again in (cls(exc), pickle.loads(pickle.dumps(exc))):
            assert (again.path, again.expected, again.value) == (exc.path, exc.expected, exc.value)


def test_option_error_rebuilt_from_a_message_keeps_its_fields() -> None:
    """From the message alone: the path and expected text read back, the value unknown. Rebuilt while the
    original is handled (as Gymnasium 1.2 and 1.4 do, with and without ``from``): the original's fields,
    which pickling then keeps although the chain itself does not pickle."""
    original = OptionTypeError("step_s", "a finite number (float, s) > 0", "60")
    alone = OptionTypeError(f"settings.yaml: {original} was raised from the environment creator")
    assert (alone.path, alone.expected, alone.value) == ("step_s", "a finite number (float, s) > 0", None)
    assert OptionError("no option named here").path is None

    for chained in ("cause", "context"):
        try:
            try:
                raise original
            except OptionError as e:
                if chained == "cause":
                    raise type(e)(f"{e} was raised from the environment creator") from e
                raise type(e)(f"{e} was raised from the environment creator")  # noqa: B904 (Gymnasium 1.2's way)
        except OptionTypeError as rebuilt:
            assert (rebuilt.path, rebuilt.value) == ("step_s", "60"), chained
            copy = pickle.loads(pickle.dumps(rebuilt))
            assert type(copy) is OptionTypeError and str(copy) == str(rebuilt)
            assert (copy.path, copy.expected, copy.value) == ("step_s", original.expected, "60"), chained


def test_option_error_keeps_its_bases() -> None:
    exc = OptionTypeError("step_s", "a number", "60")
    assert isinstance(exc, TypeError) and isinstance(exc, ConfigError) and isinstance(exc, PlanetNavError)
    assert not isinstance(OptionError("step_s", "a number", -1.0), TypeError)


def test_with_prefix_keeps_the_class_and_the_fields() -> None:
    """A training YAML's error names its file in front and stays the TypeError gym.make raises."""
    exc = errors.with_prefix(OptionTypeError("step_s", "a number", "60"), "run.yaml")
    assert type(exc) is OptionTypeError and str(exc).startswith("run.yaml: step_s must be a number")
    assert (exc.path, exc.expected, exc.value) == ("step_s", "a number", "60")
    unknown = errors.with_prefix(UnknownOptionError("got an unexpected keyword argument 'x'"), "run.yaml")
    assert type(unknown) is UnknownOptionError and isinstance(unknown, TypeError)
