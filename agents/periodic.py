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

Sessions (the operations scenarios, ``docs/operations.md`` §3.3): with ``session`` given,
``periodic:period=144,session=12,phase=30,cycle=0-1`` images for ``session`` steps out of every ``period``
steps, starting at step ``phase`` (an integer in ``[0, period)``): step ``k`` is in a session when
``(k - phase) mod period < session``, and session number ``n = floor((k - phase) / period)`` images
``cycle[n mod len(cycle)]`` (the next visible planet of the cycle with ``skip_invisible``). Between
sessions the agent chooses the environment's last action, "stay at the mission attitude" (the engine
thrusts), when the environment has it (``idle_action``); otherwise it keeps to the last session's planet.
Here ``period`` is the spacing of sessions, not the dwell per planet. Without ``session`` (and ``phase``
0) the schedule is the plain one above, unchanged.

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
        session: int | None = None,
        phase: int = 0,
    ) -> None:
        super().__init__(env)
        if isinstance(period, bool) or not isinstance(period, int | np.integer) or period < 1:
            raise ValueError(f"periodic: period must be an integer number of steps >= 1, got {period!r}")
        self.period = int(period)
        self.cycle = parse_cycle(cycle, self.config.planets)
        self.skip_invisible = bool(skip_invisible)
        cycle_text = "-".join(str(i) for i in self.cycle)
        self.name = f"periodic:period={self.period},cycle={cycle_text}"
        if isinstance(phase, bool) or not isinstance(phase, int | np.integer) or not 0 <= phase < self.period:
            raise ValueError(
                f"periodic: phase must be an integer number of steps in [0, period = {self.period}), "
                f"got {phase!r}"
            )
        bad_type = isinstance(session, bool) or not isinstance(session, int | np.integer)
        if session is not None and (bad_type or not 1 <= session <= self.period):
            raise ValueError(
                f"periodic: session must be an integer number of steps in [1, period = {self.period}], "
                f"got {session!r}"
            )
        if phase and session is None:
            raise ValueError(f"periodic: phase={phase} needs session=<steps imaging per period>")
        self.session = None if session is None else int(session)
        self.phase = int(phase)
        # The environment's "stay at the mission attitude" / "camera off" action, chosen between sessions.
        self._stay = self.n_targets if self.config.idle_action else None
        self._last = self.cycle[0]
        if self.session is not None:
            self.name = (
                f"periodic:period={self.period},session={self.session},phase={self.phase},cycle={cycle_text}"
            )
        self._k = 0

    def reset(self, seed: int | None = None) -> None:
        self._k = 0
        self._last = self.cycle[0]

    def in_session(self, k: int) -> bool:
        """Whether step ``k`` images (always without ``session``)."""
        return self.session is None or (k - self.phase) % self.period < self.session

    def scheduled(self, k: int) -> int:
        """Position in the cycle scheduled at step ``k`` (with ``session``: of the session ``k`` is in or
        last was in)."""
        if self.session is None:
            return (k // self.period) % len(self.cycle)
        return ((k - self.phase) // self.period) % len(self.cycle)

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        k = self._k
        self._k += 1
        if self.session is not None and not self.in_session(k):
            return self._last if self._stay is None else self._stay
        self._last = self._imaged(obs, self.scheduled(k))
        return self._last

    def _imaged(self, obs: ParsedObservation, pos: int) -> int:
        """The planet imaged for cycle position ``pos``: it, or the next visible one (``skip_invisible``)."""
        if not self.skip_invisible:
            return self.cycle[pos]
        visible = obs.planet_observable
        for j in range(len(self.cycle)):
            idx = self.cycle[(pos + j) % len(self.cycle)]
            if visible[idx]:
                return idx
        return self.cycle[pos]  # nothing visible: keep to the schedule
