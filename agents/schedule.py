"""A blind schedule: a fixed cycle of targets, each held a fixed number of steps, the same in every episode.

Spec syntax (``make_agent`` / ``train.py --agents``): ``schedule:targets=0-1-2,steps=8-4-4``. ``targets``
lists target indices (planets, then pulsars: ``config.planets + config.pulsars``) or names in visiting order,
separated by ``-``, or ``off``: the "camera off" action (environments with ``idle_action=True``; on the
operations scenarios a schedule of sessions, ``targets=0-off-1-off,steps=12-420``); ``steps`` is one dwell
in environment steps for every entry, or one per entry; ``phase`` (steps, default 0) skips that much of the
cycle at the start. Step ``k`` of the episode (counted from :meth:`reset`) points at the entry whose dwell
covers ``(k + phase) mod sum(steps)``.

It ignores the observation entirely (unlike ``periodic``, whose ``skip_invisible`` reads the visibility
flags): it is the family the suite's score takes its zero from, the best policy that cannot read the state
(:mod:`planetnav_train.suite.blind` searches it). On the Mars approach its cycles include the pulsars.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import ParsedObservation, TargetAgent, parse_observation


def _entries(text: str | int | float, what: str) -> list[str]:
    items = [s.strip() for s in str(text).split("-")]
    if not items or any(s == "" for s in items):
        raise ValueError(f"schedule: {what} {text!r} is empty or has an empty entry; e.g. {what}=0-1-2")
    return items


class ScheduleAgent(TargetAgent):
    """Targets of ``targets`` in turn, ``steps`` environment steps each (module docstring). In ``target`` mode
    the action is the scheduled index and the observation is never read; in the torque modes the scheduled
    planet is executed by the agent-side PD law (:class:`~planetnav_agents.base.TargetAgent`), which reads
    the attitude: the choice stays blind, the pointing does not."""

    name = "schedule"
    requires_idle_action = False

    def __init__(
        self, env: gym.Env, targets: str | int = "0-1", steps: str | int = 10, phase: int = 0
    ) -> None:
        super().__init__(env)
        cfg = self.config
        names = [n.lower() for n in (*cfg.planets, *cfg.pulsars)]
        idx: list[int] = []
        for item in _entries(targets, "targets"):
            low = item.lower()
            if low.isdigit() and int(low) < len(names):
                idx.append(int(low))
            elif low in names:
                idx.append(names.index(low))
            elif low == "off":
                if not cfg.idle_action:
                    raise ValueError(
                        "schedule: target 'off' needs the 'camera off' action, an environment built with "
                        "idle_action=True"
                    )
                idx.append(cfg.n_targets)  # the last discrete action
            else:
                raise ValueError(
                    f"schedule: target {item!r} is neither an index 0..{len(names) - 1}, one of {names}, "
                    "nor off"
                )
        dwell = []
        for item in _entries(steps, "steps"):
            if not item.isdigit() or int(item) < 1:
                raise ValueError(f"schedule: steps entry {item!r} must be an integer >= 1")
            dwell.append(int(item))
        if len(dwell) == 1:
            dwell = dwell * len(idx)
        if len(dwell) != len(idx):
            raise ValueError(
                f"schedule: steps={steps!r} gives {len(dwell)} dwells for {len(idx)} targets; give one, or "
                "one "
                "per target"
            )
        #: The target of each step of one cycle.
        self.cycle = np.repeat(np.asarray(idx, dtype=np.int64), dwell)
        if not isinstance(phase, int) or isinstance(phase, bool) or phase < 0:
            raise ValueError(f"schedule: phase {phase!r} must be an integer >= 0 (steps)")
        shown = ["off" if i == cfg.n_targets else str(i) for i in idx]
        self.name = f"schedule:targets={'-'.join(shown)},steps={'-'.join(map(str, dwell))}"
        if phase:
            self.name += f",phase={phase}"
        self.phase = phase
        self._k = phase

    def reset(self, seed: int | None = None) -> None:
        self._k = self.phase

    def _next(self) -> int:
        target = int(self.cycle[self._k % self.cycle.size])
        self._k += 1
        return target

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        return self._next()

    def act(self, observation: Any, info: dict[str, Any]) -> Any:
        if self.config.action_mode == "target":
            return self._next()  # blind: the observation is not even parsed
        return self.encode(parse_observation(observation, self.env), info, self._next())
