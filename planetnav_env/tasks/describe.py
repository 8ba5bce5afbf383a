"""Markdown descriptions of a declared version's observation, action and reward, from its declaration and
the spaces the environment builds from it (``planetnav_env.envs.spaces``): the lines of a task card that the
environment defines. The suite's facts (budget, zero point, references) are written beside them by
:mod:`planetnav_train.suite.cards`.
"""

from __future__ import annotations

import numpy as np
from gymnasium import spaces as gym_spaces

from planetnav_env.config import EnvConfig
from planetnav_env.core.layout import ObservationLayout
from planetnav_env.envs.spaces import action_space, observation_space
from planetnav_env.sensors.pulsar import pulsar
from planetnav_env.tasks.spec import TaskVersion


def observation_size(version: TaskVersion) -> int:
    """Floats of the flat observation (the ``Box`` that ``gymnasium.make`` reports)."""
    cfg = version.config()
    return int(np.prod(observation_space(cfg, ObservationLayout.for_config(cfg)).shape))


def observation_text(version: TaskVersion) -> str:
    """``Box`` of N float32: the blocks by name with their sizes, in order."""
    layout = ObservationLayout.for_config(version.config())
    blocks = ", ".join(f"`{name}` ({stop - start})" for name, start, stop, _ in layout.blocks)
    return f"`Box` of {observation_size(version)} float32: {blocks}"


def _target_names(cfg: EnvConfig) -> list[str]:
    """Planets by name (imaged), then pulsars by B name (timed), in action order."""
    return [f"image {p.capitalize()}" if cfg.pulsars else p.capitalize() for p in cfg.planets] + [
        f"time {pulsar(name).bname}" for name in cfg.pulsars
    ]


def _box(space: gym_spaces.Space) -> str:
    assert isinstance(space, gym_spaces.Box)
    low, high = float(space.low.min()), float(space.high.max())
    return f"`Box({low:g}, {high:g}, {tuple(space.shape)})`"


def action_text(version: TaskVersion) -> str:
    """The action space, what each action does, and how long a decision holds it."""
    cfg = version.config()
    space = action_space(cfg)
    limit = cfg.attitude.wheel_torque_limit
    torque = (
        f"in units of {cfg.torque_action_scale:g} of the wheel torque limit "
        f"({cfg.torque_action_scale * limit:g} N m per body axis)"
    )
    mode = cfg.action_mode
    if mode == "target":
        targets = ", ".join(f"{k} {n}" for k, n in enumerate(_target_names(cfg)))
        text = f"`Discrete({space.n})`: " if isinstance(space, gym_spaces.Discrete) else ""
        text += f"the target ({targets}), the PD law slewing to it and holding it"
        if cfg.idle_action:
            last = "stay at the thrust attitude (the engine thrusts)" if cfg.operations else "camera off"
            text += f", or {cfg.n_targets}: {last}"
        if cfg.target_actions == "relative":
            text += "; relative: 0 keeps the current target and k moves k places along the target order"
    elif mode == "torque":
        text = f"{_box(space)}: the wheel torque on the body in body axes, {torque}"
    elif mode == "target+torque":
        n = cfg.n_planets
        text = (
            f"{_box(space)}: `argmax(a[:{n}])` picks the planet the PD law slews to; `a[{n}:]` is a residual "
            f"torque {torque}, added to the PD command"
        )
    else:  # hybrid
        n = cfg.n_planets
        text = (
            f"{_box(space)}: option `k = argmax(a[:{n + 1}])`; for k < {n} the PD law slews to planet k and "
            f"`a[{n + 1}:]` is ignored, for k = {n} the torque `a[{n + 1}:]`, {torque}, drives the wheels"
        )
    step = f"{cfg.step_s:g} s"
    if cfg.decision_steps == 1:
        hold = f"one decision per physics step of {step}"
    else:
        hold = (
            f"one decision holds its action {cfg.decision_steps} physics steps of {step} "
            f"({cfg.decision_steps * cfg.step_s:,g} s); `env.spec.max_episode_steps` = "
            f"{cfg.episode_decisions:,} decisions"
        )
    return f"{text}; {hold}"


def reward_text(version: TaskVersion) -> str:
    """The reward per physics step as the core computes it."""
    cfg = version.config()
    scale = f"{cfg.reward_scale_km:g} km"
    summed = ", summed over a decision" if cfg.decision_steps > 1 else ""
    if cfg.operations is not None:
        term = (
            "the filter's predicted 1σ mapped to the encounter, computable on board"
            if cfg.reward == "covariance"
            else "the true position error mapped to the encounter, privileged"
        )
        return (
            f"the increments of the objective J, `-(w * delta-v lost this step + the deadline terms reached "
            f"this step) / {scale}` per physics step{summed}, with w = {cfg.operations.cost_weight:g} km per "
            f"m/s, summing to `-J / {scale}` over the episode; the deadline term is {term}"
        )
    if cfg.reward == "covariance":
        return (
            f"`-sqrt(trace P_rr) / {scale}` per physics step{summed} (the filter's predicted RMS position "
            "error, computable on board)"
        )
    return f"`-|r_est - r_true| / {scale}` per physics step{summed} (the true position error, privileged)"
