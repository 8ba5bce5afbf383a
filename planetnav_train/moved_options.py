"""The decision options a training configuration once set and the environment now owns, and the error
that names the environment option to set instead.

The decision interface (the hold, absolute or relative targets, the steps since each target was last
measured) is the environment's: ``EnvConfig.decision_steps``, ``target_actions`` and
``observe_since_measured`` (``docs/environment.md``), set in a training YAML's ``env:`` section. A
configuration (or a saved run's ``config.yaml``) that still uses the training-side names is rejected with
:func:`moved_option_error`, before anything is built.
"""

from __future__ import annotations

from typing import Any

from planetnav_env.errors import ConfigError

#: Training-side name -> the environment option that replaces it.
MOVED_OPTIONS = {
    "action_repeat": "decision_steps",
    "relative_actions": "target_actions",
    "since_measured": "observe_since_measured",
}
#: The values of the former keys that changed nothing, which every older run's ``config.yaml`` holds.
NO_OP_VALUES = {"action_repeat": 1, "relative_actions": False}


def is_no_op(name: str, value: Any) -> bool:
    """Whether ``value`` of the former key ``name`` is its no-op value (``action_repeat: 1``,
    ``relative_actions: false``; the type checked too: ``True == 1`` in Python)."""
    noop = NO_OP_VALUES.get(name)
    return noop is not None and type(value) is type(noop) and value == noop


def moved_options_in(data: Any) -> list[tuple[str, Any]]:
    """The former decision options a configuration mapping ``data`` uses, as (name, value), in the order
    of :data:`MOVED_OPTIONS`; their no-op values do not count (an older run's ``config.yaml`` reads)."""
    if not hasattr(data, "get"):
        return []
    found = [
        (n, data[n]) for n in ("action_repeat", "relative_actions") if n in data and not is_no_op(n, data[n])
    ]
    features = data.get("features")
    if isinstance(features, list | tuple) and "since_measured" in features:
        found.append(("since_measured", None))
    return found


def moved_option_error(name: str, value: Any = None, base_decision_steps: int = 1) -> ConfigError:
    """The :class:`ConfigError` for the training-side decision option ``name`` (a key of
    :data:`MOVED_OPTIONS`) given ``value``: it names the env option and the value that keeps the meaning.

    ``base_decision_steps``: the ``decision_steps`` of the environment the option was layered over (an
    ``action_repeat`` of k over an env holding ``d`` physics steps held ``k * d``)."""
    if name == "action_repeat":
        ok = isinstance(value, int) and not isinstance(value, bool) and value >= 1
        setting = (
            f"decision_steps={value * base_decision_steps}" if ok else "decision_steps (an integer >= 1)"
        )
        what = "a training option"
    elif name == "relative_actions":
        setting = {True: "target_actions='relative'", False: "target_actions='absolute' (the default)"}.get(
            value if isinstance(value, bool) else None, "target_actions ('absolute' or 'relative')"
        )
        what = "a training option"
    elif name == "since_measured":
        setting, what = "observe_since_measured=true", "a training feature"
    else:
        raise KeyError(f"{name!r} is not one of the moved options {sorted(MOVED_OPTIONS)}")
    return ConfigError(
        f"{name} is no longer {what}: set env option {setting} in the config's env section "
        "(see docs/environment.md, 'The decision interface')"
    )
