"""Agents for the planetnav environments, behind one interface (:class:`planetnav_agents.base.Agent`).

``make_agent(name_or_path, env)`` builds a rule agent by name, or a learned policy from a saved model
through the loaders that the training packages register (:mod:`planetnav_agents.loaders`):

============== ==========================================================================================
name           agent
============== ==========================================================================================
baseline       the thesis's rule: the nearest planet by the filter's estimate
               (:mod:`planetnav_agents.baseline`)
baseline-size  the same rule ranking by estimated apparent diameter
greedy         the planet whose measurements shrink the position covariance most, slew time counted
greedy-pd      greedy + PD, the wheel-torque tasks' reference: greedy over a 180-s horizon (in time, any
               step), executed by the PD law (as wheel torques in ``torque`` mode;
               :func:`planetnav_agents.greedy.greedy_pd`)
random         a uniformly random action each step
idle           never measures (needs ``idle_action=True``, so ``action_mode="target"`` only)
zero           zero wheel torque every step (``action_mode="torque"`` only): the camera drifts with the body
periodic       fixed schedule: the planets of a cycle in turn, ``period`` steps each
               (:mod:`planetnav_agents.periodic`)
schedule       blind schedule: a fixed cycle of targets (planets and pulsars), a dwell each, ignoring the
               observation (:mod:`planetnav_agents.schedule`; the suite's zero point searches it)
optimum        operations scenarios: the best open-loop session schedule found at reset on the filter's
               covariance prediction (:mod:`planetnav_agents.optimum`)
planner        non-myopic rollout planner on copies of the environment, scored by the filter's
               covariance (:mod:`planetnav_agents.planner`)
PATH           a saved SB3 model (``.zip`` or a ``runs/<name>/`` directory), deterministic actions
               (loader of :mod:`planetnav_train.sb3`; needs the ``[train]`` extra)
PATH           an RLlib checkpoint (a ``runs/<name>/`` directory of ``algo: rllib_ppo``, or the checkpoint
               directory itself; needs the ``[ray]`` extra), the policy's mode (:mod:`planetnav_rl.agent`)
PATH@sampled   the same model, actions sampled from the policy (seeded by ``reset(seed)``)
suite:TASK     the benchmark suite's shipped baseline of TASK (``suite:Cruise-Target-v0``): the best
               raw-track policy, stored in ``planetnav_train/baselines/`` (:mod:`planetnav_train.shipped`)
============== ==========================================================================================

Parameters follow the name: ``NAME:key=value,key=value`` (``periodic:period=60,cycle=0-1-2``,
``greedy:horizon=5``, ``planner:horizon=120,replan=10``). Values are read as integers, floats,
``true``/``false`` or text; an unknown key or a bad value raises ``ValueError`` naming it and the keys the
agent accepts. :func:`not_applicable` says why an agent cannot run in an environment (``idle`` outside
``target`` mode); the evaluation harness skips such agents with that note.
"""

from __future__ import annotations

# ruff: noqa: E402  (the stale-cache check below must run before the submodules declare their kernels)
from pathlib import Path

import planetnav_env
from planetnav_env.numerics.numba_cache import drop_stale_cache

# gain.py's compiled kernels call the environment's: a change on either side makes them stale.
drop_stale_cache(Path(__file__).parent, [Path(__file__).parent, Path(planetnav_env.__file__).parent])

import functools
import inspect
from collections.abc import Callable
from pathlib import Path
from typing import Any

import gymnasium as gym

from planetnav_agents.base import (
    Agent,
    NotApplicableError,
    ParsedObservation,
    TargetAgent,
    parse_observation,
    unwrapped_config,
)
from planetnav_agents.baseline import BaselineAgent
from planetnav_agents.greedy import GreedyAgent, greedy_pd
from planetnav_agents.loaders import MISSING_LOADERS_HINT, find_loader, register_loader
from planetnav_agents.optimum import OptimumAgent
from planetnav_agents.periodic import PeriodicAgent
from planetnav_agents.planner import PlannerAgent
from planetnav_agents.schedule import ScheduleAgent
from planetnav_agents.simple import IdleAgent, RandomAgent, ZeroTorqueAgent
from planetnav_env.config import EnvConfig

AGENTS: dict[str, Callable[..., Agent]] = {
    "baseline": functools.partial(BaselineAgent, criterion="distance"),
    "baseline-size": functools.partial(BaselineAgent, criterion="size"),
    "greedy": GreedyAgent,
    "greedy-pd": greedy_pd,
    "periodic": PeriodicAgent,
    "planner": PlannerAgent,
    "schedule": ScheduleAgent,
    "random": RandomAgent,
    "idle": IdleAgent,
    "zero": ZeroTorqueAgent,
}

#: Agents that act only in an operations scenario (``config.operations``, e.g. ThrustArc-TCM): routed by
#: name like :data:`AGENTS`, reported by :func:`not_applicable` elsewhere (kept out of :data:`AGENTS`, the
#: agents every environment can run).
OPERATIONS_AGENTS: dict[str, Callable[..., Agent]] = {"optimum": OptimumAgent}

#: Agents that need the environment's "camera off" action (the harness builds their env with it).
NEEDS_IDLE_ACTION = frozenset({"idle"})


#: Suffix of a model path that evaluates the policy's sampled actions instead of its argmax.
SAMPLED_SUFFIX = "@sampled"


def strip_sampled(spec: str) -> str:
    """The model path of a ``PATH@sampled`` agent spec (other specs unchanged)."""
    s = str(spec)
    return s[: -len(SAMPLED_SUFFIX)] if s.endswith(SAMPLED_SUFFIX) else s


def _convert(text: str) -> Any:
    """A spec value: int, float, bool (``true``/``false``) or the text itself."""
    low = text.lower()
    if low in ("true", "false"):
        return low == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _accepted_keys(factory: Callable[..., Agent]) -> list[str]:
    """Keyword parameters a registered agent's constructor accepts (besides ``env``, minus fixed ones)."""
    fixed: set[str] = set()
    target = factory
    if isinstance(factory, functools.partial):
        fixed, target = set(factory.keywords), factory.func
    params = inspect.signature(target).parameters
    return [k for k in params if k not in {"self", "env", *fixed}]


def _factory(name: str) -> Callable[..., Agent] | None:
    """The constructor of a registered agent name (:data:`AGENTS` or :data:`OPERATIONS_AGENTS`)."""
    return AGENTS.get(name, OPERATIONS_AGENTS.get(name))


def parse_spec(spec: str | Path) -> tuple[str, dict[str, Any]]:
    """``"NAME:key=value,..."`` -> (NAME, {key: value}) for a registered NAME; anything else (a model
    path, ``PATH@sampled``) -> (spec, {}).

    Raises ``ValueError`` naming a malformed, unknown or repeated key.
    """
    text = str(spec)
    name, sep, rest = text.partition(":")
    if not sep or _factory(name) is None:
        return text, {}
    accepted = _accepted_keys(_factory(name))
    params: dict[str, Any] = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or not key or not value.strip():
            raise ValueError(f"agent spec {text!r}: {item!r} is not key=value")
        if key not in accepted:
            raise ValueError(f"agent spec {text!r}: unknown parameter {key!r}; {name} accepts {accepted}")
        if key in params:
            raise ValueError(f"agent spec {text!r}: parameter {key!r} given twice")
        params[key] = _convert(value.strip())
    return name, params


def requires_idle_action(name_or_path: str) -> bool:
    """Whether the agent ``name_or_path`` needs an environment with ``idle_action=True``."""
    return parse_spec(name_or_path)[0] in NEEDS_IDLE_ACTION


def acts_at_physics_step(name_or_path: str) -> bool:
    """Whether agent ``name_or_path`` is a rule agent written for the physics-step interface (absolute
    targets, one decision per physics step, the base observation): every registered agent but ``random``,
    which samples whatever action space it is given. Evaluation runs such an agent on
    :meth:`EnvConfig.at_physics_step` of the task's configuration: the same physics, seeds and objective."""
    name, _ = parse_spec(name_or_path)
    return (name in AGENTS or name in OPERATIONS_AGENTS) and name != "random"


def not_applicable(name_or_path: str, config: EnvConfig) -> str | None:
    """Why agent ``name_or_path`` cannot act in an environment of ``config``, or None when it can.

    Only what is known before building the agent: ``idle`` needs the discrete "camera off" action, which
    exists in ``target`` mode only; an agent of :data:`OPERATIONS_AGENTS` needs ``config.operations``. (A
    saved model whose spaces do not match raises :class:`NotApplicableError` when it is built.)
    """
    name, _ = parse_spec(name_or_path)
    if name in OPERATIONS_AGENTS and config.operations is None:
        return f"{name} needs an operations scenario (config.operations), e.g. planetnav/ThrustArc-TCM-v0"
    if name == "zero" and config.action_mode != "torque":
        return (
            "zero commands wheel torques: it needs action_mode 'torque' "
            f"(this environment: {config.action_mode!r})"
        )
    if name in NEEDS_IDLE_ACTION and config.action_mode != "target":
        return (
            f"{name} needs the discrete 'camera off' action, which only action_mode 'target' has "
            f"(this environment: {config.action_mode!r})"
        )
    return None


def make_agent(name_or_path: str | Path, env: gym.Env, **kwargs: Any) -> Agent:
    """An agent by registered name (see the module docstring) or from a saved model through the first
    :mod:`~planetnav_agents.loaders` loader that takes it.

    ``kwargs`` go to the agent's constructor (e.g. ``horizon=60`` for ``greedy``, ``algo="ppo"`` for a
    model). Raises ``ValueError`` naming the known agents when the name is neither a rule agent nor taken
    by a loader.
    """
    key, params = parse_spec(name_or_path)
    if acts_at_physics_step(str(name_or_path)):
        cfg = unwrapped_config(env)
        if cfg.at_physics_step() is not cfg:
            raise NotApplicableError(
                f"{key} acts at the physics step with absolute targets and the base observation; this "
                f"environment holds decisions {cfg.decision_steps} steps, takes {cfg.target_actions} targets "
                f"and observe_since_measured={cfg.observe_since_measured}: build it from "
                "config.at_physics_step() (the same physics), as train.py evaluate and compare do"
            )
    if params:
        try:
            agent = _factory(key)(env, **params, **kwargs)
        except TypeError as exc:  # e.g. a keyword given both in the spec and in kwargs
            raise ValueError(f"agent spec {name_or_path!r}: {exc}") from None
        if agent.name == key:
            # Reports key results by name: "greedy:horizon=10" must not read as (or overwrite) "greedy".
            agent.name = str(name_or_path)
        return agent
    if key.endswith(SAMPLED_SUFFIX):
        # "PATH@sampled": the saved policy's actions are sampled, not its argmax (seeded by reset(seed)).
        key = key[: -len(SAMPLED_SUFFIX)]
        kwargs.setdefault("deterministic", False)
    if _factory(key) is not None:
        return _factory(key)(env, **kwargs)
    loader = find_loader(key)
    if loader is not None:
        return loader.load(key, env, **kwargs)
    known = sorted({*AGENTS, *OPERATIONS_AGENTS})
    raise ValueError(
        f"unknown agent {key!r}: not one of {known}, and no registered loader takes it (a shipped "
        f"baseline suite:<task> or a saved model at that path); {MISSING_LOADERS_HINT}"
    )


__all__ = [
    "AGENTS",
    "OPERATIONS_AGENTS",
    "Agent",
    "BaselineAgent",
    "GreedyAgent",
    "IdleAgent",
    "NotApplicableError",
    "OptimumAgent",
    "ParsedObservation",
    "PeriodicAgent",
    "PlannerAgent",
    "RandomAgent",
    "ScheduleAgent",
    "TargetAgent",
    "ZeroTorqueAgent",
    "acts_at_physics_step",
    "make_agent",
    "not_applicable",
    "parse_observation",
    "parse_spec",
    "register_loader",
    "requires_idle_action",
    "strip_sampled",
]
