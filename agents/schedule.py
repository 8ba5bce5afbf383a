"""A blind schedule: a fixed cycle of targets, each held a fixed number of steps, the same in every episode.

Spec syntax (``make_agent`` / ``train.py --agents``): ``schedule:targets=0-1-2,steps=8-4-4``. ``targets``
lists target indices (planets, then pulsars: ``config.planets + config.pulsars``) or names in visiting order,
separated by ``-``; ``steps`` is one dwell in environment steps for every entry, or one per entry. Step ``k``
of the episode (counted from :meth:`reset`) points at the entry whose dwell covers ``k mod sum(steps)``.

It ignores the observation entirely (unlike ``periodic``, whose ``skip_invisible`` reads the visibility
flags): it is the family the suite's score takes its zero from, the best policy that cannot read the state
(:mod:`planetnav_train.suite.blind` searches it). On the Mars approach its cycles include the pulsars.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import Agent, unwrapped_config


def _entries(text: str | int | float, what: str) -> list[str]:
    items = [s.strip() for s in str(text).split("-")]
    if not items or any(s == "" for s in items):
        raise ValueError(f"schedule: {what} {text!r} is empty or has an empty entry; e.g. {what}=0-1-2")
    return items


class ScheduleAgent(Agent):
    """Targets of ``targets`` in turn, ``steps`` environment steps each (module docstring)."""

    name = "schedule"

    def __init__(self, env: gym.Env, targets: str | int = "0-1", steps: str | int = 10) -> None:
        cfg = unwrapped_config(env)
        if cfg.action_mode != "target":
            raise ValueError(f"schedule: needs action_mode 'target', got {cfg.action_mode!r}")
        names = [n.lower() for n in (*cfg.planets, *cfg.pulsars)]
        idx: list[int] = []
        for item in _entries(targets, "targets"):
            low = item.lower()
            if low.isdigit() and int(low) < len(names):
                idx.append(int(low))
            elif low in names:
                idx.append(names.index(low))
            else:
                raise ValueError(
                    f"schedule: target {item!r} is neither an index 0..{len(names) - 1} nor one of {names}"
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
        self.env = env
        #: The target of each step of one cycle.
        self.cycle = np.repeat(np.asarray(idx, dtype=np.int64), dwell)
        self.name = f"schedule:targets={'-'.join(map(str, idx))},steps={'-'.join(map(str, dwell))}"
        self._k = 0

    def reset(self, seed: int | None = None) -> None:
        self._k = 0

    def act(self, observation: Any, info: dict[str, Any]) -> int:
        target = int(self.cycle[self._k % self.cycle.size])
        self._k += 1
        return target
