"""Fixed periodic switching: look at the planets of a cycle in turn, ``period`` steps each.

Spec syntax (``make_agent`` / ``train.py --agents``): ``periodic:period=60,cycle=0-1-2``, where
``period`` is the dwell on each planet in environment steps (an integer >= 1; 60 steps of 60 s = 1 h in
cruise) and ``cycle`` the planets in visiting order, by index into ``config.planets`` or by name
(``venus-mars``), separated by ``-``. A planet may repeat (``0-1-0-2``). ``periodic`` alone uses the
defaults below, the best setting of the periodic sweep on the default cruise
(``docs/agents.md``).

The schedule is open loop: step ``k`` of the episode (counted from :meth:`reset`) looks at
``cycle[(k // period) % len(cycle)]``. With ``skip_invisible`` (default) a scheduled planet the camera
could not see even if pointed at it (the observation's flag) is replaced by the next visible one of the
cycle, so the schedule does not stare into the Sun's glare on random cruises.

Sessions (the operations scenarios): with ``session`` given,
``periodic:period=144,session=12,phase=30,cycle=0-1`` images for ``session`` steps out of every ``period``
steps, starting at step ``phase`` (an integer in ``[0, period)``): step ``k`` is in a session when
``(k - phase) mod period < session``, and session number ``n = floor((k - phase) / period)`` images
``cycle[n mod len(cycle)]`` (the next visible planet of the cycle with ``skip_invisible``). Between
sessions the agent chooses the environment's last action, "stay at the mission attitude" (the engine
thrusts), when the environment has it (``idle_action``); otherwise it keeps to the last session's planet.
Here ``period`` is the spacing of sessions, not the dwell per planet. Without ``session`` (and ``phase``
0) the schedule is the plain one above, unchanged.

Deadline-anchored sessions (the operations scenarios): with ``lead`` given,
``periodic:lead=0,session=24-48-12,start=6,dwell=6,cycle=0-1-2`` images in one block before each knowledge
deadline (TCM) of ``config.operations.deadlines_s`` instead of every ``period`` steps. The environment
reaches deadline ``j`` at the end of step count ``d_j = ceil(deadlines_s[j] / step_s)`` (the first step end
at or after its epoch; the same rule as the environment and ``optimum``), and the block before it images
the steps ``k`` with ``d_j - lead - session_j <= k < d_j - lead``: it ends ``lead`` steps (``lead = 0``:
exactly) before the deadline. ``session`` is one block length in steps for every deadline, or one per
deadline separated by ``-`` (``24-48-12``; 0 skips that deadline). ``start`` (default 0: none) adds a
session of that many steps at the episode's start, steps ``0 <= k < start``, where the 1000-km prior makes
images worth most. ``dwell`` (default: a whole session) splits every session into pieces of ``dwell``
steps (the last may be shorter); piece number ``n`` of the episode, counted over all sessions, images
``cycle[n mod len(cycle)]`` (the next visible planet of the cycle with ``skip_invisible``), so a block can
alternate planets, the triangulating pairs ``optimum`` places before the deadlines. ``period`` and
``phase`` do not apply. A block that would reach back before step 0 or into the session before it is
clipped: it starts where that one ends (empty if nothing is left), so that a setting tuned on the 21-day
episode still runs on shorter ones. Units: steps of ``step_s`` (600 s on ThrustArc-TCM: 6 steps = 1 h).

It is the bar the issue sets for a learned policy: a policy that only learned "switch now and then"
should not beat the best fixed schedule.
"""

from __future__ import annotations

import math
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
    """Planets of ``cycle`` in turn, ``period`` steps each, or sessions every ``period`` steps, or blocks
    anchored on the deadlines (see the module docstring)."""

    requires_idle_action = False

    def __init__(
        self,
        env: gym.Env,
        period: int | None = None,
        cycle: str | Sequence[int | str] = DEFAULT_CYCLE,
        skip_invisible: bool = True,
        session: int | str | None = None,
        phase: int = 0,
        lead: int | None = None,
        start: int = 0,
        dwell: int | None = None,
    ) -> None:
        super().__init__(env)
        self.cycle = parse_cycle(cycle, self.config.planets)
        self.skip_invisible = bool(skip_invisible)
        cycle_text = "-".join(str(i) for i in self.cycle)
        # The environment's "stay at the mission attitude" / "camera off" action, chosen between sessions.
        self._stay = self.n_targets if self.config.idle_action else None
        self._last = self.cycle[0]
        self._k = 0
        #: Deadline mode: cycle position imaged at each step of the episode, -1 = stay (None otherwise).
        self._plan: np.ndarray | None = None
        if lead is not None:
            if period is not None or phase:
                raise ValueError(
                    f"periodic: lead={lead!r} anchors sessions on the deadlines; period={period!r} and "
                    f"phase={phase!r} do not apply (leave them out)"
                )
            self.period = 0
            self.session = None
            self.phase = 0
            self.name = self._deadline_plan(lead, session, start, dwell, cycle_text)
            return
        if start or dwell is not None:
            raise ValueError(
                f"periodic: start={start!r} and dwell={dwell!r} belong to deadline-anchored sessions; "
                "they need lead=<steps from a block's end to its deadline>"
            )
        period = DEFAULT_PERIOD if period is None else period
        if isinstance(period, bool) or not isinstance(period, int | np.integer) or period < 1:
            raise ValueError(f"periodic: period must be an integer number of steps >= 1, got {period!r}")
        self.period = int(period)
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
        if self.session is not None:
            self.name = (
                f"periodic:period={self.period},session={self.session},phase={self.phase},cycle={cycle_text}"
            )

    def _deadline_plan(self, lead: Any, session: Any, start: Any, dwell: Any, cycle_text: str) -> str:
        """Fill :attr:`_plan` for deadline-anchored sessions (module docstring); returns the agent's name.

        Raises ``ValueError`` naming the bad value: a non-integer or negative ``lead``/``start``/block
        length, ``dwell`` < 1, a ``session`` list whose length is not the number of deadlines, or no
        operations scenario.
        """

        def steps(name: str, value: Any, low: int) -> int:
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ValueError(
                    f"periodic: {name} must be an integer number of steps >= {low}, got {value!r}"
                )
            return int(value)

        ops = self.config.operations
        if ops is None:
            raise ValueError(
                f"periodic: lead={lead!r} anchors sessions on the deadlines of an operations scenario "
                "(config.operations, e.g. planetnav/ThrustArc-TCM-v0); this environment has none"
            )
        lead_k = steps("lead", lead, 0)
        start_k = steps("start", start, 0)
        dwell_k = None if dwell is None else steps("dwell", dwell, 1)
        n_dl = len(ops.deadlines_s)
        if session is None:
            raise ValueError(
                f"periodic: lead={lead_k} needs session=<steps per block> (one value, or {n_dl} joined by -)"
            )
        if isinstance(session, str):
            parts = [p.strip() for p in session.split("-")]
            if len(parts) != n_dl or not all(p.isdigit() for p in parts):
                raise ValueError(
                    f"periodic: session={session!r} must be one integer or {n_dl} integers >= 0 joined by - "
                    f"(one block length per deadline, in steps)"
                )
            blocks = [int(p) for p in parts]
        else:
            blocks = [steps("session", session, 1)] * n_dl
        dt = float(self.config.step_s)
        n = int(self.config.episode_steps)
        # The env reaches a deadline at the first step end at or after its epoch (core.operations).
        dl_steps = [math.ceil(d / dt - 1e-9) for d in ops.deadlines_s]
        spans = [(0, start_k)] if start_k else []
        for d, length in zip(dl_steps, blocks, strict=True):
            # Clipped, not refused: a block that would reach back before step 0 or into the session
            # before it starts where that one ends (the same rule then runs on shorter episodes, e.g.
            # the 30-step smoke versions of the configs, whose deadlines are a few steps apart).
            lo = max(d - lead_k - length, spans[-1][1] if spans else 0)
            hi = d - lead_k
            if length and hi > lo:
                spans.append((lo, hi))
        plan = np.full(n, -1, dtype=np.int64)
        piece = 0
        for lo, hi in spans:
            size = hi - lo if dwell_k is None else dwell_k
            for a in range(lo, hi, size):
                plan[a : min(a + size, hi, n)] = piece % len(self.cycle)
                piece += 1
        self._plan = plan
        self.lead, self.start, self.dwell, self.blocks = lead_k, start_k, dwell_k, tuple(blocks)
        session_text = str(blocks[0]) if len(set(blocks)) == 1 else "-".join(str(b) for b in blocks)
        name = f"periodic:lead={lead_k},session={session_text}"
        if start_k:
            name += f",start={start_k}"
        if dwell_k is not None:
            name += f",dwell={dwell_k}"
        return f"{name},cycle={cycle_text}"

    def reset(self, seed: int | None = None) -> None:
        self._k = 0
        self._last = self.cycle[0]

    def in_session(self, k: int) -> bool:
        """Whether step ``k`` images (always without ``session`` or ``lead``)."""
        if self._plan is not None:
            return 0 <= k < self._plan.size and self._plan[k] >= 0
        return self.session is None or (k - self.phase) % self.period < self.session

    def scheduled(self, k: int) -> int:
        """Position in the cycle scheduled at step ``k`` (with ``session``: of the session ``k`` is in or
        last was in; with ``lead``: of the piece ``k`` is in, meaningful only where :meth:`in_session`)."""
        if self._plan is not None:
            return int(self._plan[k]) if 0 <= k < self._plan.size else 0
        if self.session is None:
            return (k // self.period) % len(self.cycle)
        return ((k - self.phase) // self.period) % len(self.cycle)

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        k = self._k
        self._k += 1
        if (self.session is not None or self._plan is not None) and not self.in_session(k):
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
