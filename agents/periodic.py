"""Fixed periodic switching: look at the planets of a cycle in turn, ``period`` steps each.

Spec syntax (``make_agent`` / ``train.py --agents``): ``periodic:period=60,cycle=0-1-2``, where
``period`` is the dwell on each planet in environment steps (an integer >= 1; 60 steps of 60 s = 1 h in
cruise) and ``cycle`` the planets in visiting order, by index into ``config.planets`` or by name
(``venus-mars``), separated by ``-``. A planet may repeat (``0-1-0-2``). ``periodic`` alone uses the
defaults below, the best setting of ``python train.py sweep-periodic`` on the default cruise
(``docs/agents.md``).

The schedule is open loop: step ``k`` of the episode (counted from :meth:`reset`) looks at
``cycle[(k // period) % len(cycle)]``. With ``skip_invisible`` (default) a scheduled planet the camera
could not see even if pointed at it (the observation's flag) is replaced by the next visible one of the
cycle, so the schedule does not stare into the Sun's glare on random cruises.

It is the bar the issue sets for a learned policy: a policy that only learned "switch now and then"
should not beat the best fixed schedule.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import ParsedObservation, TargetAgent

DEFAULT_PERIOD = 10
DEFAULT_CYCLE = "0-1"


def parse_cycle(cycle: str | Sequence[int | str], planets: Sequence[str]) -> tuple[int, ...]:
    """Planet indices of ``cycle`` (``"0-1-2"``, ``"venus-mars"`` or a sequence of indices/names).

    Raises ``ValueError`` naming the bad entry and the environment's planets.
    """
    items: Sequence[int | str]
    if isinstance(cycle, str):
        items = [s.strip() for s in cycle.split("-")]
    elif isinstance(cycle, int):
        items = [cycle]
    else:
        items = list(cycle)
    if not items or any(item == "" for item in items):
        raise ValueError(f"periodic: cycle {cycle!r} is empty or has an empty entry; e.g. cycle=0-1-2")
    names = [p.lower() for p in planets]
    out = []
    for item in items:
        text = str(item).strip().lower()
        if text.lstrip("-").isdigit():
            idx = int(text)
            if not 0 <= idx < len(names):
                raise ValueError(
                    f"periodic: cycle entry {item!r} is not a planet index 0..{len(names) - 1} of {names}"
                )
        elif text in names:
            idx = names.index(text)
        else:
            raise ValueError(
                f"periodic: cycle entry {item!r} is neither an index nor one of the planets {names}"
            )
        out.append(idx)
    return tuple(out)


class PeriodicAgent(TargetAgent):
    """Planets of ``cycle`` in turn, ``period`` steps each (see the module docstring)."""

    requires_idle_action = False

    def __init__(
        self,
        env: gym.Env,
        period: int = DEFAULT_PERIOD,
        cycle: str | Sequence[int | str] = DEFAULT_CYCLE,
        skip_invisible: bool = True,
    ) -> None:
        super().__init__(env)
        if isinstance(period, bool) or not isinstance(period, int | np.integer) or period < 1:
            raise ValueError(f"periodic: period must be an integer number of steps >= 1, got {period!r}")
        self.period = int(period)
        self.cycle = parse_cycle(cycle, self.config.planets)
        self.skip_invisible = bool(skip_invisible)
        self.name = f"periodic:period={self.period},cycle={'-'.join(str(i) for i in self.cycle)}"
        self._k = 0

    def reset(self, seed: int | None = None) -> None:
        self._k = 0

    def scheduled(self, k: int) -> int:
        """Position in the cycle scheduled at step ``k``."""
        return (k // self.period) % len(self.cycle)

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        pos = self.scheduled(self._k)
        self._k += 1
        if not self.skip_invisible:
            return self.cycle[pos]
        visible = obs.planet_observable
        for j in range(len(self.cycle)):
            idx = self.cycle[(pos + j) % len(self.cycle)]
            if visible[idx]:
                return idx
        return self.cycle[pos]  # nothing visible: keep to the schedule
