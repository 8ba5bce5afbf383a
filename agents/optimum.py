"""``optimum``: the open-loop session schedule of an operations scenario, searched at reset on the filter's
covariance prediction (docs/agents.md, docs/tasks/ThrustArc-TCM.md).

Units: times [s], steps of ``step_s``, covariances [km^2, km^2/s, km^2/s^2], σ [km], Δv [m/s], the cost
weight ``w`` [km per m/s], J [km].

Why open loop is enough. On ``ThrustArc-TCM`` the filter's covariance does not depend on the measured
values: the thrust noise ``Q`` depends only on the attitude history (the actions), and ``H``, ``R`` depend on
the estimated trajectory only through directions that move by ~σ / distance ~1e-5 rad. With
``reward: covariance`` the objective ``J = Σ_k σ_k + w Δv_lost`` is then a deterministic function of the
schedule and the seed's geometry, and the best schedule computed at reset is the best policy.

The model (built once at reset from what the spacecraft knows: ``info["filter"]``, the star-tracker
attitude, the reported rates and wheels, the ephemeris table), every piece the environment's own kernel:

* the estimated trajectory with the engine on throughout: ``estimation.ekf_kernels.predict_kernel`` (its
  STM Φ_k is kept per step), ``core.operations.planned_direction`` / ``apply_thrust`` (the planned thrust
  direction u_k and the nominal thrust); the schedule's sessions move it by ~5 km, which changes Φ and H
  by ~1e-8 and is left out;
* per step and planet, ``H`` and ``R`` of an image at the step's end (``planet_model_kernel`` with the
  predicted line-of-sight basis, as :func:`planetnav_env.core.what_if.predicted_planet_trace`) and whether
  the camera sees the planet (``core.observation.observe_row``'s "observable if pointed at" flag from the
  predicted estimate: field, occultation, Sun exclusion, detection, disk size);
* the thrust fraction f_k of each step from the attitude: 1 when staying settled, 0 on a planet, and, on a
  step that slews between the thrust attitude and a planet, the time within the attitude tolerance of u_k
  found by running the env's closed-loop PD sub-steps (``attitude.pointing.substeps_kernel``,
  ``core.operations.thrust_axis_on``) from the settled attitude (``frame_kernel``) of the previous target;
  the first ``grid`` steps from the star-tracker attitude, reported rates and wheels at reset;
* per step ``P <- Φ_k P Φ_k^T + Q_proc`` (``covariance_predict_kernel``, the product ``predict_kernel``
  forms, with the stored Φ_k: the search evaluates thousands of schedules and recomputing the RK4 STM
  each time would cost ~10x), then
  ``core.operations.add_thrust_q`` with f_k, then for an image of a visible planet the core's Joseph
  update ``update_kernel`` (zero innovation: P does not depend on it); at each deadline
  ``sqrt(coasted_position_trace(P, E - t_k))`` (``core.what_if``), the env's σ_k.

The search. A schedule is a set of sessions of ``session`` steps on one planet each, starting on a grid of
``grid`` steps (not in the first grid slot, while the spacecraft settles from its random initial attitude),
not overlapping; between sessions the spacecraft stays at the mission attitude. From each start (the empty
schedule and the tuned periodic rule's schedule, ``periodic:period=432,session=12,phase=108,cycle=0-1-2``),
a local search alternates (a) best insertion of one session (every free grid start × planet) while it
lowers J and (b) first-improvement moves of one session (remove, change planet, shift by ±1, ±2, ±4, ±8
grid slots) until none lowers J; the best schedule found over the starts is kept. Local search is not
guaranteed to reach the global optimum, so ``optimum`` is the best schedule found, a reference and not a
bound. Cost: a few thousand schedule evaluations of ~0.3 ms, seconds per episode.

The agent then plays its schedule: the session's planet (even if it leaves the field: the env then takes
no image, and the model counted none), "stay" (the last action) otherwise. ``predicted_objective_km`` is
the model's J of the played schedule, which ``tests/agents/test_optimum.py`` checks against the env's
``info["objective"]``.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from numba import njit

from planetnav_agents.base import ParsedObservation, TargetAgent, unwrapped_config
from planetnav_env.attitude import quaternion as qt
from planetnav_env.attitude.plant import Plant
from planetnav_env.attitude.pointing import LoopScratch, PdLoop, frame_kernel, substeps_kernel
from planetnav_env.core import layout as L
from planetnav_env.core.observation import observe_row
from planetnav_env.core.operations import add_thrust_q, apply_thrust, planned_direction, thrust_axis_on
from planetnav_env.core.records import make_scratch
from planetnav_env.core.row_ephemeris import eval_channel, perturbers_at, planets_at
from planetnav_env.core.what_if import coasted_position_trace
from planetnav_env.estimation.ekf_kernels import (
    OrbitModel,
    PredictScratch,
    covariance_predict_kernel,
    matmul_kernel,
    planet_model_kernel,
    predict_kernel,
    update_kernel,
)
from planetnav_env.estimation.measurement_kernels import los_basis_kernel

#: The tuned periodic rule (a session of 12 steps every 432 from step 108) whose schedule starts the search.
PERIODIC_START = (432, 12, 108, (0, 1, 2))


@njit(cache=True)
def _nominal_path(prm, eph, f1, p1, i1, obs1, x0, n_steps, t0):  # pragma: no cover - compiled
    """The estimated trajectory from ``x0`` (6,) at absolute time ``t0`` [s] with the engine on throughout,
    and per step k: Φ_k (K, 6, 6), u_k (K, 3), the stay frame (K, 3, 3) and each planet's frame
    (K, P, 3, 3) at the step's start (the PD law's references), and at the step's end each planet's H
    (K, P, 3, 6), R (K, P, 3, 3), m (P,) and visibility (K, P). ``f1``, ``p1``, ``i1``, ``obs1``: a scratch
    row (only the epoch, estimate and step count are set) for ``observe_row``."""
    ps = prm.scalars[0]
    dt = ps.step_s
    n_p = ps.n_planets
    sc = make_scratch(prm)
    phis = np.zeros((n_steps, 6, 6))
    us = np.zeros((n_steps, 3))
    fr_stay = np.zeros((n_steps, 3, 3))
    fr_pl = np.zeros((n_steps, n_p, 3, 3))
    hs = np.zeros((n_steps, n_p, 3, 6))
    rs = np.zeros((n_steps, n_p, 3, 3))
    ms = np.zeros(n_p, np.int64)
    vis = np.zeros((n_steps, n_p), np.bool_)
    xe = x0.copy()
    pdummy = np.zeros((6, 6))
    pws = PredictScratch(w6=sc.w6, v6=sc.v6, phi=sc.phi, tmp=sc.tmp)
    u = np.zeros(3)
    dirv = np.zeros(3)
    roll = np.zeros(3)
    f1[0, L.F_T0] = t0
    i1[0, L.I_TARGET] = -1
    base = ps.obs_planets
    for k in range(n_steps):
        t = t0 + k * dt
        i1[0, L.I_K] = k
        eval_channel(prm, eph, f1, 0, t, ps.ch_central, sc.central)
        planned_direction(xe, u)
        for j in range(3):
            us[k, j] = u[j]
            roll[j] = xe[j] + sc.central[j]
        frame_kernel(u, roll, fr_stay[k])
        planets_at(prm, eph, f1, 0, t, sc.planets)
        for a in range(n_p):
            for j in range(3):
                dirv[j] = sc.planets[a, j] - (xe[j] + sc.central[j])
            frame_kernel(dirv, roll, fr_pl[k, a])
        perturbers_at(prm, eph, f1, 0, t, dt, sc.pert)
        orbit = OrbitModel(
            mu=ps.mu, p0=sc.pert[0], p1=sc.pert[1], p2=sc.pert[2], mus=prm.mus, srp_k=0.0, srp_sun=-1
        )
        predict_kernel(xe, pdummy, dt, orbit, prm.qproc, ps.euler != 0, pws)
        phis[k] = sc.phi
        # The nominal thrust over a whole step: t_on = dt, position moment dt^2 / 2.
        apply_thrust(xe, ps.ops_acc, u, dt, 0.5 * dt * dt)
        t1 = t + dt
        i1[0, L.I_K] = k + 1
        eval_channel(prm, eph, f1, 0, t1, ps.ch_central, sc.central)
        planets_at(prm, eph, f1, 0, t1, sc.planets)
        for a in range(n_p):
            for j in range(3):
                dirv[j] = sc.planets[a, j] - sc.central[j]  # the planet in the filter's frame
            if ps.kind >= 2:
                los_basis_kernel(dirv, xe, sc.basis)
            m = planet_model_kernel(
                xe[:3], dirv, 2.0 * prm.radii[a], ps.kind, ps.sig_dir, ps.sig_size, sc.basis, sc.h,
                hs[k, a], rs[k, a],
            )  # fmt: skip
            ms[a] = m
        for j in range(6):
            f1[0, L.F_XE + j] = xe[j]
        observe_row(prm, f1, p1, i1, eph, obs1, 0, sc, False)
        for a in range(n_p):
            vis[k, a] = obs1[0, base + L.TARGET_FEATURES * a + L.TF_OBSERVABLE] > 0.5
    return phis, us, fr_stay, fr_pl, hs, rs, ms, vis


@njit(cache=True)
def _slew_on_time(prm, sc, y0, hw0, frame, u, n_steps, out_on):  # pragma: no cover - compiled
    """From attitude state ``y0`` (7,: q, ω) and wheel momentum ``hw0`` (3,), ``n_steps`` steps of the env's
    PD sub-steps toward ``frame`` (fine sub-steps, as the env runs a slewing step); ``out_on[s]`` <- the time
    [s] of step s with the thrust axis within the tolerance of ``u`` (checked after each sub-step, as
    ``step_row``); ``sc``: a ``make_scratch`` record."""
    ps = prm.scalars[0]
    y = y0.copy()
    hw = hw0.copy()
    u_last = np.zeros(3)
    zero = np.zeros(3)
    loop = PdLoop(
        plant=Plant(jm=prm.jm, jinv=prm.jinv, tau_max=prm.tau_max, h_max=prm.h_max), k_a=ps.k_a, k_w=ps.k_w
    )
    ws = LoopScratch(work=sc.work, rq=sc.rq, a=sc.a, u_cmd=sc.u_cmd)
    for s in range(n_steps):
        t_on = 0.0
        for _ in range(ps.n_sub):
            substeps_kernel(y, hw, True, frame, zero, zero, 1, ps.substep_s, loop, ws, u_last)
            if thrust_axis_on(y, prm.boresight, u, ps.ops_cos_tol):
                t_on += ps.substep_s
        out_on[s] = t_on


@njit(cache=True)
def _slew_table(prm, q_from, q_to_frames, us, ks, hw0, out):  # pragma: no cover - compiled
    """``out[g, a]`` <- thrust time [s] of the slewing step ``ks[g]`` from the settled attitude
    ``q_from[g, a]`` (4,) toward ``q_to_frames[g, a]`` (3, 3), thrust direction ``us[ks[g]]``."""
    sc = make_scratch(prm)
    y = np.zeros(7)
    one = np.zeros(1)
    for g in range(ks.shape[0]):
        for a in range(q_from.shape[1]):
            for j in range(4):
                y[j] = q_from[g, a, j]
            for j in range(3):
                y[4 + j] = 0.0
            _slew_on_time(prm, sc, y, hw0, q_to_frames[g, a], us[ks[g]], 1, one)
            out[g, a] = one[0]


@njit(cache=True)
def _stay_blocks(phis, qproc, us, grid, dt, q_par, q_perp):  # pragma: no cover - compiled
    """Per grid slot b, the map of its ``grid`` held-stay steps composed: ``phi_b`` (the product of the
    steps' Φ) and ``q_b`` (their process and thrust noise, f = 1, carried to the slot's end), so that
    ``P <- phi_b P phi_b^T + q_b`` equals the steps one by one (up to rounding)."""
    n_b = phis.shape[0] // grid
    phi_b = np.zeros((n_b, 6, 6))
    q_b = np.zeros((n_b, 6, 6))
    tmp = np.empty((6, 6))
    for b in range(n_b):
        for i in range(6):
            phi_b[b, i, i] = 1.0
        for k in range(b * grid, (b + 1) * grid):
            covariance_predict_kernel(q_b[b], phis[k], qproc, tmp)
            add_thrust_q(q_b[b], dt, 1.0, q_par, q_perp, us[k])
            matmul_kernel(phis[k], phi_b[b], 6, 6, 6, tmp)  # the estimation kernels' one 6x6 product
            phi_b[b] = tmp
    return phi_b, q_b


@njit(cache=True)
def _objective(
    acts,
    k0,
    p0,
    j0,
    phis,
    qproc,
    us,
    hs,
    rs,
    ms,
    vis,
    init_on,
    enter_on,
    leave_on,
    grid,
    dl_step,
    dl_tgo,
    dt,
    acc,
    q_par,
    q_perp,
    w,
    wrap,
    k_end,
    phi_b,
    q_b,
    p_cache,
    j_cache,
):  # pragma: no cover - compiled
    """J [km] of the step actions ``acts`` (K,: -1 stay, else the planet) from step ``k0`` with covariance
    ``p0`` and J so far ``j0`` (the prefix, unchanged by the candidate). Steps < ``grid`` take the
    thrust time ``init_on``; a step that enters a session from stay ``enter_on[k // grid, planet]``, one
    that leaves it ``leave_on[k // grid, planet]``; a held stay dt, a held planet or a planet switch 0.
    A grid slot held at stay throughout takes its composed map (``_stay_blocks``) in one product. The
    covariance stops after the last deadline (``k_end``): the rest adds only Δv. When ``p_cache`` has
    rows, the covariance and J before each grid step are stored there."""
    p = p0.copy()
    tmp = np.empty((6, 6))
    uw = np.empty((5, 6, 6))
    xd = np.zeros(6)
    z = np.zeros(3)
    h = np.zeros(3)
    jv = j0
    n = acts.shape[0]
    n_dl = dl_step.shape[0]
    store = p_cache.shape[0] > 0
    cost_rate = w * acc * 1000.0  # km per second of thrust lost
    k = k0
    while k < n:
        a = acts[k]
        prev = acts[k - 1] if k > 0 else -1
        if k % grid == 0:
            if store:
                p_cache[k // grid] = p
                j_cache[k // grid] = jv
            if k >= grid and prev < 0 and k + grid <= k_end:
                held = True
                for c in range(k, k + grid):
                    if acts[c] >= 0:
                        held = False
                        break
                inner = False
                for d in range(n_dl):
                    if k + 1 <= dl_step[d] < k + grid:
                        inner = True
                if held and not inner:
                    covariance_predict_kernel(p, phi_b[k // grid], q_b[k // grid], tmp)
                    k += grid
                    for d in range(n_dl):
                        if dl_step[d] == k:
                            jv += math.sqrt(max(coasted_position_trace(p, dl_tgo[d]), 0.0))
                    continue
        if k < grid:
            t_on = init_on[k] if a < 0 else 0.0
        elif a == prev:
            t_on = dt if a < 0 else 0.0
        elif prev < 0:
            t_on = enter_on[k // grid, a]
        elif a < 0:
            t_on = leave_on[k // grid, prev]
        else:
            t_on = 0.0
        jv += cost_rate * (dt - t_on)
        if k < k_end:
            covariance_predict_kernel(p, phis[k], qproc, tmp)
            if t_on > 0.0:
                add_thrust_q(p, dt, t_on / dt, q_par, q_perp, us[k])
            if a >= 0 and vis[k, a]:
                update_kernel(xd, p, z, h, hs[k, a], rs[k, a], ms[a], wrap, np.inf, uw)
            for d in range(n_dl):
                if dl_step[d] == k + 1:
                    jv += math.sqrt(max(coasted_position_trace(p, dl_tgo[d]), 0.0))
        k += 1
    return jv


class ScheduleModel:
    """The covariance model of one episode (module docstring) and J of any session schedule."""

    def __init__(
        self, env: gym.Env, x0: np.ndarray, p0: np.ndarray, obs: ParsedObservation, t0: float, grid: int
    ) -> None:
        u = env.unwrapped
        cfg = unwrapped_config(env)
        ops = cfg.operations
        prm = u.core_params
        ps = prm.scalars[0]
        self.grid = grid
        self.dt = dt = float(cfg.step_s)
        self.n_steps = n = int(cfg.episode_steps)
        self.n_planets = n_p = cfg.n_planets
        core = u.core
        # A scratch row: only the epoch, the estimate and the step count are written by _nominal_path.
        f1 = np.zeros((1, L.NF))
        for j in range(4):
            f1[0, L.F_QE + j] = 1.0 if j == 0 else 0.0
        p1 = np.ascontiguousarray(p0, dtype=float)[None].copy()
        i1 = np.zeros((1, L.NI), dtype=np.int64)
        obs1 = np.zeros((1, core.obs.shape[1]))
        x0 = np.ascontiguousarray(x0, dtype=float)
        out = _nominal_path(prm, core.eph[:1], f1, p1, i1, obs1, x0, n, float(t0))
        self.phis, self.us, fr_stay, fr_pl, self.hs, self.rs, self.ms, self.vis = out
        self.qproc = np.ascontiguousarray(prm.qproc)
        self.p0 = np.ascontiguousarray(p0, dtype=float).copy()
        self.acc = float(ps["ops_acc"])
        self.q_par, self.q_perp = (float(v) for v in ops.psd_km2_s3)
        self.w = float(ops.cost_weight)
        self.wrap = 1 if int(ps["kind"]) <= 1 else -1
        # The env reaches a deadline at the first step end at or after its epoch (core.operations).
        self.dl_step = np.array([math.ceil(d / dt - 1e-9) for d in ops.deadlines_s], dtype=np.int64)
        self.dl_tgo = np.array([max(float(ops.encounter_s) - s * dt, 0.0) for s in self.dl_step])
        self.k_end = int(min(self.dl_step.max(), n))
        # Slews: settled attitudes are the PD frames' (body -> inertial DCM = frame^T).
        ks = np.arange(0, n, grid, dtype=np.int64)
        q_stay = qt.from_dcm_body_to_inertial(np.swapaxes(fr_stay[ks], -1, -2))
        q_pl = qt.from_dcm_body_to_inertial(np.swapaxes(fr_pl[ks], -1, -2))
        hw0 = np.ascontiguousarray(obs.wheel_fraction * np.asarray(prm.h_max, dtype=float))
        self.enter_on = np.zeros((ks.size, n_p))
        self.leave_on = np.zeros((ks.size, n_p))
        q_from = np.ascontiguousarray(np.repeat(q_stay[:, None], n_p, axis=1))
        _slew_table(prm, q_from, np.ascontiguousarray(fr_pl[ks]), self.us, ks, hw0, self.enter_on)
        to_stay = np.ascontiguousarray(np.repeat(fr_stay[ks][:, None], n_p, axis=1))
        _slew_table(prm, np.ascontiguousarray(q_pl), to_stay, self.us, ks, hw0, self.leave_on)
        # The first grid steps stay, slewing from the attitude at reset (star tracker, reported rates).
        y0 = np.concatenate([obs.q, obs.rates_rad_s]).astype(float)
        self.init_on = np.zeros(grid)
        _slew_on_time(
            prm, make_scratch(prm), y0, hw0, np.ascontiguousarray(fr_stay[0]), self.us[0], grid, self.init_on
        )
        self.phi_b, self.q_b = _stay_blocks(self.phis, self.qproc, self.us, grid, dt, self.q_par, self.q_perp)
        self._empty_cache = np.zeros((0, 6, 6))
        self._empty_j = np.zeros(0)

    def actions(self, sessions: list[tuple[int, int, int]]) -> np.ndarray:
        """(K,) step actions (-1 stay, else the planet) of sessions ``(start step, planet, steps)``."""
        acts = np.full(self.n_steps, -1, dtype=np.int64)
        for s, a, n in sessions:
            acts[s : s + n] = a
        return acts

    def objective(
        self, acts: np.ndarray, k0: int = 0, p_start: np.ndarray | None = None, j_start: float = 0.0,
        cache: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> float:  # fmt: skip
        """J [km] of the step actions ``acts`` (from step ``k0`` with covariance ``p_start`` and J so far
        ``j_start``; ``cache`` receives the covariance and J before each grid step)."""
        p = self.p0 if p_start is None else p_start
        pc, jc = cache if cache is not None else (self._empty_cache, self._empty_j)
        return float(
            _objective(
                acts,
                k0,
                p,
                j_start,
                self.phis,
                self.qproc,
                self.us,
                self.hs,
                self.rs,
                self.ms,
                self.vis,
                self.init_on,
                self.enter_on,
                self.leave_on,
                self.grid,
                self.dl_step,
                self.dl_tgo,
                self.dt,
                self.acc,
                self.q_par,
                self.q_perp,
                self.w,
                self.wrap,
                self.k_end,
                self.phi_b,
                self.q_b,
                pc,
                jc,
            )
        )


Session = tuple[int, int, int]  # (start step, planet, length in steps)


class ScheduleSearch:
    """Local search over session schedules on a :class:`ScheduleModel` (module docstring)."""

    SHIFTS = (-8, -4, -2, -1, 1, 2, 4, 8)

    def __init__(self, model: ScheduleModel, session: int) -> None:
        self.m = model
        self.session = session
        self.g = model.grid
        self.n_grid = model.n_steps // self.g
        # Insertions on every other grid start: the moves' shifts of ±1 slot refine the placement.
        self.stride = 2
        self.lengths = sorted({self.g, session})
        self.evaluations = 0
        n_g = self.n_grid + 1
        self._pc = np.zeros((n_g, 6, 6))
        self._jc = np.zeros(n_g)

    def _ok(self, sessions: list[Session]) -> bool:
        """Sessions inside the episode, after the first grid slot, at least one grid slot long, not
        overlapping."""
        last = -1
        for s, _, n in sorted(sessions):
            if s < self.g or n < self.g or s + n > self.m.n_steps or s < last:
                return False
            last = s + n
        return True

    def full(self, sessions: list[Session]) -> float:
        """J of ``sessions``, filling the prefix cache."""
        self.evaluations += 1
        return self.m.objective(self.m.actions(sessions), cache=(self._pc, self._jc))

    def from_cache(self, sessions: list[Session], first_step: int) -> float:
        """J of ``sessions``, which differ from the cached schedule only from step ``first_step`` on."""
        self.evaluations += 1
        gi = max(first_step // self.g, 0)
        acts = self.m.actions(sessions)
        return self.m.objective(acts, gi * self.g, self._pc[gi], float(self._jc[gi]))

    def insert_best(self, sessions: list[Session], j_now: float) -> tuple[list[Session], float]:
        """The best schedule with one more session of ``session`` steps (every other free grid start x
        planet), if it lowers J."""
        self.full(sessions)
        best, best_j = None, j_now
        span = -(-self.session // self.g)
        for gs in range(1, self.n_grid - span + 1, self.stride):
            s = gs * self.g
            for n in self.lengths:
                for a in range(self.m.n_planets):
                    cand = sorted([*sessions, (s, a, n)])
                    if not self._ok(cand):
                        break
                    j = self.from_cache(cand, s)
                    if j < best_j - 1e-9:
                        best, best_j = cand, j
        return (best, best_j) if best is not None else (sessions, j_now)

    def moves(self, sessions: list[Session], j_now: float) -> tuple[list[Session], float]:
        """First-improvement moves of one session (remove, change planet, shift, one grid slot longer or
        shorter at either end) until none lowers J."""
        g = self.g
        improved = True
        while improved:
            improved = False
            self.full(sessions)
            for idx, (s, a, n) in enumerate(sessions):
                rest = sessions[:idx] + sessions[idx + 1 :]
                alts = [(s, b, n) for b in range(self.m.n_planets) if b != a]
                alts += [(s + d * g, a, n) for d in self.SHIFTS]
                alts += [(s, a, n + g), (s, a, n - g), (s - g, a, n + g), (s + g, a, n - g)]
                cands = [rest] + [sorted([*rest, c]) for c in alts]
                for cand in cands:
                    if not self._ok(cand):
                        continue
                    first = min([s] + [c[0] for c in cand if c not in sessions])
                    j = self.from_cache(cand, first)
                    if j < j_now - 1e-9:
                        sessions, j_now, improved = cand, j, True
                        break
                if improved:
                    break
        return sessions, j_now

    def improve(self, sessions: list[Session]) -> tuple[list[Session], float]:
        """Insertion and moves alternated until neither lowers J."""
        sessions = sorted(sessions)
        j_now = self.full(sessions)
        while True:
            sessions, j_now = self.moves(sessions, j_now)
            new, j_new = self.insert_best(sessions, j_now)
            if new is sessions:
                return sessions, j_now
            sessions, j_now = new, j_new


def periodic_sessions(model: ScheduleModel, session: int) -> list[Session]:
    """The tuned periodic rule's sessions (:data:`PERIODIC_START`) moved to the search grid: the cycle's
    planet, or its next planet visible at the session's start."""
    period, _, phase, cycle = PERIODIC_START
    out, n = [], 0
    g = model.grid
    for s in range(phase, model.n_steps - session + 1, period):
        sg = max(g, round(s / g) * g)
        a = cycle[n % len(cycle)]
        for c in range(len(cycle)):
            b = cycle[(n + c) % len(cycle)]
            if b < model.n_planets and model.vis[sg, b]:
                a = b
                break
        if a < model.n_planets and sg + session <= model.n_steps:
            out.append((sg, a, session))
        n += 1
    return out


class OptimumAgent(TargetAgent):
    """The best open-loop session schedule found at reset (module docstring)."""

    name = "optimum"
    requires_idle_action = True

    def __init__(self, env: gym.Env, session: int = 12, grid: int = 6) -> None:
        super().__init__(env)
        cfg = self.config
        if cfg.operations is None:
            raise ValueError(
                "optimum needs an operations scenario (config.operations), e.g. planetnav/ThrustArc-TCM-v0"
            )
        for key, value in (("session", session), ("grid", grid)):
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
                raise ValueError(f"optimum: {key} must be an integer number of steps >= 1, got {value!r}")
        if session % grid:
            raise ValueError(f"optimum: session={session} must be a multiple of grid={grid} (steps)")
        if session + grid > cfg.episode_steps:
            raise ValueError(
                f"optimum: session={session} + grid={grid} steps exceed the episode "
                f"({cfg.episode_steps} steps)"
            )
        self.session = int(session)
        self.grid = int(grid)
        self.stay = cfg.n_targets
        self.reset()

    def reset(self, seed: int | None = None) -> None:
        self.k = 0
        self.acts: np.ndarray | None = None
        self.sessions: list[Session] = []
        self.predicted_objective_km = math.nan
        self.evaluations = 0

    def plan(self, obs: ParsedObservation, info: dict[str, Any]) -> None:
        """Build the model from the state at reset and search (module docstring)."""
        x = self.estimate(obs, info)
        p = np.asarray(info["filter"]["P"], dtype=float)
        model = ScheduleModel(self.env, x, p, obs, float(info["time_s"]), self.grid)
        search = ScheduleSearch(model, self.session)
        best, best_j = [], math.inf
        for start in ([], periodic_sessions(model, self.session)):
            s, j = search.improve([c for c in start if search._ok([c])])
            if j < best_j:
                best, best_j = s, j
        self.model = model
        self.sessions = best
        self.acts = model.actions(best)
        self.predicted_objective_km = best_j
        self.evaluations = search.evaluations

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        if self.acts is None:
            self.plan(obs, info)
        k = self.k
        self.k += 1
        if k >= self.acts.size or self.acts[k] < 0:
            return self.stay
        return int(self.acts[k])
