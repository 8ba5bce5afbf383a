"""The typed records a task declares itself with: :class:`TaskSpec` holds a task's versions, each a
:class:`TaskVersion` of a :class:`Layout` (what fixes the compiled layout), :class:`Params` (the numbers),
a :class:`Reward`, the learners' :class:`Interface` and the rule agents' one, and a note for the card.

A version resolves to the environment options that ``gymnasium.make`` passes (:meth:`TaskVersion.options`)
and to an :class:`~planetnav_env.config.EnvConfig` (:meth:`TaskVersion.config`). Options a version does not
state keep :class:`EnvConfig`'s declared default (``docs/environment.md``, "Options"). Each record checks
its own values when it is built (a :class:`ConfigError` naming the field and the value); the rules that tie
options together are :class:`EnvConfig`'s, applied by :meth:`TaskVersion.config` (``tests/env/test_tasks.py``
builds every version).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, fields
from typing import Any

from planetnav_env.config import (
    ACTION_MODES,
    OBSERVATION_SCALINGS,
    REWARDS,
    SCENARIOS,
    TARGET_ACTIONS,
    EnvConfig,
    OperationsSettings,
)
from planetnav_env.core.layout import OBSERVATION_BLOCKS
from planetnav_env.errors import ConfigError
from planetnav_env.estimation.ekf import FilterConfig
from planetnav_env.world import WorldConfig

#: The namespace of every planetnav id.
NAMESPACE = "planetnav"

#: Optional observation blocks a layout may add after the fixed ones, each switched by the option
#: ``observe_<name>`` (``since_measured`` belongs to the decision :class:`Interface`, the
#: ``operations`` block to the scenario's :attr:`Params.operations`): every block that
#: :data:`planetnav_env.core.layout.OBSERVATION_BLOCKS` declares, so a new block needs no line here.
BLOCKS = tuple(b.name for b in OBSERVATION_BLOCKS if b.name != "since_measured")


def _choice(name: str, value: Any, choices: tuple[str, ...]) -> None:
    if value not in choices:
        raise ConfigError(f"{name} must be one of {list(choices)}, got {value!r}")


@dataclass(frozen=True)
class Layout:
    """What fixes the compiled layout of a version: the state's columns, the observation's width and the
    action space (with the interface's ``since_measured`` block and the operations block of
    :attr:`Params.operations`).

    scenario: one of :data:`planetnav_env.config.SCENARIOS`. planets: the bodies the camera may target, in
    action order. pulsars: the X-ray pulsars the detector may time, after the planets. action_mode: one of
    :data:`planetnav_env.config.ACTION_MODES`. idle_action: a last discrete action (camera off, or stay at
    the mission attitude with operations). blocks: the optional observation blocks of :data:`BLOCKS`.
    """

    scenario: str
    planets: tuple[str, ...]
    action_mode: str
    pulsars: tuple[str, ...] = ()
    idle_action: bool = False
    blocks: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        _choice("layout.scenario", self.scenario, SCENARIOS)
        _choice("layout.action_mode", self.action_mode, ACTION_MODES)
        for block in self.blocks:
            _choice("layout.blocks", block, BLOCKS)

    def options(self) -> dict[str, Any]:
        """The environment options of this layout."""
        return {
            "scenario": self.scenario,
            "planets": self.planets,
            "pulsars": self.pulsars,
            "action_mode": self.action_mode,
            "idle_action": self.idle_action,
            **{f"observe_{b}": b in self.blocks for b in BLOCKS},
        }


@dataclass(frozen=True)
class Params:
    """The numbers of a version: timing, noise, scales and the events the filter does not model.

    step_s [s]: the physics step; episode_steps: physics steps before truncation. attitude_substep_s and
    settled_substep_s [s]: the attitude integration steps (None: EnvConfig's 1 s and 10 s).
    torque_action_scale: the torque an action of 1 commands, as a fraction of the wheel limit (None: 1).
    filter: the navigation filter's settings (None: FilterConfig's defaults). image_success_min and
    prior_long_sigma_km: the per-episode image failures and the prior's long axis [km] (None: neither).
    operations: the thrust arc and its knowledge deadlines (None: no operations scenario).
    world: the world the truth is simulated in, apart from the onboard model (a
    :class:`~planetnav_env.world.WorldConfig`, or a preset's name, ``"matched"`` or ``"flight"``); None
    leaves EnvConfig's default, the matched world, in which the truth is the onboard model's own physics.
    """

    step_s: float
    episode_steps: int
    attitude_substep_s: float | None = None
    settled_substep_s: float | None = None
    torque_action_scale: float | None = None
    filter: FilterConfig | None = None
    image_success_min: float | None = None
    prior_long_sigma_km: float | None = None
    operations: OperationsSettings | None = None
    world: WorldConfig | None = None

    def __post_init__(self) -> None:
        if self.world is not None:
            object.__setattr__(self, "world", WorldConfig.coerce(self.world))  # names 'world' when bad

    def options(self) -> dict[str, Any]:
        """The environment options of these parameters (the unset ones left to EnvConfig's defaults)."""
        out: dict[str, Any] = {"step_s": self.step_s, "episode_steps": self.episode_steps}
        for name in ("attitude_substep_s", "settled_substep_s", "torque_action_scale",
                     "image_success_min", "prior_long_sigma_km"):  # fmt: skip
            value = getattr(self, name)
            if value is not None:
                out[name] = value
        for name in ("filter", "operations", "world"):
            value = getattr(self, name)
            if value is not None:
                out[name] = {g.name: getattr(value, g.name) for g in fields(value) if g.init}
        return out


@dataclass(frozen=True)
class Reward:
    """The reward per physics step, summed over a decision. kind ``truth``: ``-|r_est - r_true| /
    scale_km`` (the true position error, privileged); ``covariance``: ``-sqrt(trace P_rr) / scale_km``
    (the filter's predicted RMS position error, computable on board). With :attr:`Params.operations` the
    reward is the increment of the scenario's objective J instead, ``-(w * delta-v lost + the deadline
    terms reached) / scale_km``, and kind picks the deadline term: the true error mapped to the encounter
    or the 1-sigma the filter predicts. ``baseline_km``: a time-only baseline subtracted from each step's
    error term before the scale (``EnvConfig.reward_baseline_km``; empty: none)."""

    kind: str
    scale_km: float
    baseline_km: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        _choice("reward.kind", self.kind, REWARDS)
        if not self.scale_km > 0:
            raise ConfigError(f"reward.scale_km must be > 0 km, got {self.scale_km!r}")
        object.__setattr__(self, "baseline_km", tuple(float(b) for b in self.baseline_km))

    def options(self) -> dict[str, Any]:
        out: dict[str, Any] = {"reward": self.kind, "reward_scale_km": self.scale_km}
        if self.baseline_km:
            out["reward_baseline_km"] = self.baseline_km
        return out


@dataclass(frozen=True)
class Interface:
    """How decisions map onto physics steps: ``decision_steps`` physics steps per decision (the action
    held, the rewards summed), ``absolute`` or ``relative`` target actions (0 keeps the target, k moves k
    places along the target order), and ``since_measured``, the observation block of what the spacecraft
    knows of its own measurement history, and ``observation_scaling`` (``raw``, or ``unit``: every column
    to order 1 by fixed constants). The default is one physics step per decision, absolute targets, no
    history block, the raw observation."""

    decision_steps: int = 1
    target_actions: str = "absolute"
    since_measured: bool = False
    observation_scaling: str = "raw"

    def __post_init__(self) -> None:
        _choice("interface.target_actions", self.target_actions, TARGET_ACTIONS)
        _choice("interface.observation_scaling", self.observation_scaling, OBSERVATION_SCALINGS)
        if not (isinstance(self.decision_steps, int) and self.decision_steps >= 1):
            raise ConfigError(f"interface.decision_steps must be an int >= 1, got {self.decision_steps!r}")

    def options(self) -> dict[str, Any]:
        return {
            "decision_steps": self.decision_steps,
            "target_actions": self.target_actions,
            "observe_since_measured": self.since_measured,
            "observation_scaling": self.observation_scaling,
        }


#: The interface a version's rule agents play unless it states another: one decision per physics step,
#: absolute targets, no history block (the same physics, seeds and objective as the learners' interface).
PHYSICS_STEP = Interface()


@dataclass(frozen=True)
class TaskVersion:
    """One registered version of a task: everything ``gymnasium.make`` builds, and the rule agents'
    interface. ``note``: what this version is, for the task's card and version table."""

    version: int
    layout: Layout
    params: Params
    reward: Reward
    interface: Interface
    note: str
    rules: Interface = PHYSICS_STEP

    def options(self) -> dict[str, Any]:
        """The environment options this version stands for, as ``gymnasium.make`` passes them."""
        return {**self.layout.options(), **self.params.options(), **self.reward.options(),
                **self.interface.options()}  # fmt: skip

    def rule_options(self) -> dict[str, Any]:
        """The options of the interface the rule agents play (:attr:`rules`): the same physics."""
        return {**self.options(), **self.rules.options()}

    def config(self, **overrides: Any) -> EnvConfig:
        """The validated configuration (with ``overrides`` over the version's options)."""
        return EnvConfig.from_dict(self.options(), **overrides)


@dataclass(frozen=True)
class Card:
    """A task's card text beside what its versions generate (``docs/tasks/<name>.md``): ``lead``, what
    the task is; ``physics``, the physics every version shares (markdown); ``commands``, shell lines."""

    lead: str
    physics: str
    commands: tuple[str, ...] = ()


@dataclass(frozen=True)
class TaskSpec:
    """A task: its name (``Cruise-Target``) and its versions, 0, 1, ... in order, and its card."""

    name: str
    versions: tuple[TaskVersion, ...]
    card: Card
    #: Where the declaration lives (the family module), for error messages and the card's pointer.
    module: str = field(default="", compare=False)

    def __post_init__(self) -> None:
        if not re.fullmatch(r"[A-Z][A-Za-z]*(-[A-Z][A-Za-z]*)*", self.name):
            raise ConfigError(f"task name {self.name!r} must be CamelCase words joined by '-'")
        got = [v.version for v in self.versions]
        if got != list(range(len(got))) or not got:
            raise ConfigError(f"task {self.name!r}: versions must be 0, 1, ... in order, got {got}")

    def env_id(self, version: int) -> str:
        """``planetnav/<name>-v<version>``."""
        return f"{NAMESPACE}/{self.name}-v{version}"

    def ids(self) -> dict[str, TaskVersion]:
        """Every version by its id."""
        return {self.env_id(v.version): v for v in self.versions}

    @property
    def latest(self) -> TaskVersion:
        return self.versions[-1]


__all__ = [
    "BLOCKS", "NAMESPACE", "PHYSICS_STEP", "Card", "Interface", "Layout", "Params", "Reward", "TaskSpec",
    "TaskVersion",
]  # fmt: skip
