"""Gate prototype of scenario B, `MarsApproach-Deadline-v0` (docs/operations.md §4), and of A′.

A covariance-only model of the Mars approach with a cost on time away from Earth pointing during DSN
passes. It asks one question before anything is built: on held-out geometries, paired, how much lower
is the objective of the best open-loop schedule found than that of the best rule, each rule at its best
setting on tuning geometries? §4 builds scenario B only if that gap is at least 15 %.

Model (what comes from the environment and what is a stated choice; docs/operations.md §4 has the table):

* Trajectory: the environment's own approach (`planetnav_env.approach.MarsApproach`, DOP853 with Mars,
  Sun, Earth and Jupiter), 96 h before closest approach (CA) down to CA, on the env's 300-s step. The
  episode is `MarsApproach-Tasking-v0`'s: 1128 steps ending 2 h before CA. `--geometry env` keeps the
  env's CA epoch (2021-02-10 12:00 TDB); `--geometry family` draws the CA epoch within ±45 d of it
  (same arrival rule: v∞ against Mars's velocity), which turns the pulsars against the line of sight.
* State transition: per 300-s step, central differences of the env's force model
  (`GravityModel.derivative`) over five 60-s RK4 sub-steps (the filter's step in docs/optical_pulsar.md).
* Mars image (one per step): the env's measurement model and noise (`planet_model_kernel` with
  `build_params`' `kind`, `sig_dir`, `sig_size` of `MarsApproach-Tasking-v0`: LOS + apparent size, 3.8″
  per axis, 2.5 px on the diameter); imageable when the disk is below the env's `alpha_max` and Mars is
  outside the camera's 30° Sun exclusion.
* Pulsar phase: one per 20-min slot (the env's 1000-s integration takes 4 steps of 300 s), `H = n / λ`,
  `R = σ_phase²` from `build_params` (Crab 0.79 km, B1937+21 0.24 km); Sun avoidance 30° and occultation
  by Mars (`pulsar_visibility`); the ambiguity rule of the env: a phase is used only if
  `3 sqrt(H P Hᵀ + R) < 1/2` cycle with the covariance before it.
* Prior and process noise: the env's filter, 100 km and 1 m/s per axis, white acceleration of PSD
  1e-16 km²/s³ (`ekf.process_noise` over each step, composed with the transitions over a slot).
* Actions: per 20-min slot (282 slots), stay at Earth pointing, image Mars (4 images), time the Crab or
  time B1937+21 (one phase each). Slews inside a slot are not modelled (the env counts a slewing step).
* Passes (stated choice, no source): one 8-h DSN pass per 24 h, its phase drawn per geometry. Cost: hours
  of pass not Earth-pointed, plus a 180-s slew back (the env's wheel-model slew, §3.1) when a look ends
  inside a pass. Outside passes time away is free.
* Objective: `J = σ(CA−24 h) + σ(CA−2 h) + w × hours of pass lost` [km], σ the position 1σ coasted to CA in
  free flight (`--mapping coasted`; the script checks it against the env's `coasted_position_trace`) or
  mapped by the trajectory's own transition matrix (`--mapping stm`, the knowledge at CA itself).
* Simplifications: the images of a slot are mapped to its end without the 15 min of process noise
  between them; the filter linearises on the truth; no gating of outliers; the greedy and the search see
  the same model (the open-loop schedule is optimal here because P does not depend on the measured values,
  the ambiguity rule included).

References: periodic rules (period, session, phase, target cycle, with or without skipping pass slots),
the deadline- and cost-aware greedy (a session when the predicted reduction of the remaining deadlines' σ
exceeds θ w × the session's cost, θ = inf: never in a pass), both swept on tuning geometries; the open-loop
optimum found by coordinate descent over the slots (single-slot changes and shifts) from the two tuned
rules' schedules, the empty one and `--restarts` random ones (a local search: its J is an upper bound on
the optimum's, so the gap it gives is a lower estimate); and a lower bound on any schedule's J (every
target in every slot at once, ungated, free), which bounds the gap from above.

`--scenario a-prime` runs A′ (`Coast-Downlink-TCM-v0`): the free-flight 2-D model of §5 without thrust,
cost in hours away from Earth (downlink), deadlines at E−14, E−5, E−1.5 d.

Run: `python configs/operations/prototype_deadline.py [--scenario b|a-prime] [--geometry env|family]
[--mapping coasted|stm] [--weights ...] [--tuning 8] [--held-out 30] [--restarts 0] [--show]`; it prints
one table per weight (B with the defaults: 4-5 CPU minutes, mostly the search; A′: seconds).
"""

from __future__ import annotations

import argparse
import copy
import itertools
import math
import time

import numpy as np
from numba import njit

from planetnav_env.approach import DEFAULT_CLOSEST_APPROACH_TDB, PERTURBERS, ApproachConfig, MarsApproach
from planetnav_env.bodies import body
from planetnav_env.config import EnvConfig
from planetnav_env.core.params import ChannelPlan, build_params
from planetnav_env.core.what_if import coasted_position_trace
from planetnav_env.estimation.ekf import process_noise
from planetnav_env.estimation.ekf_kernels import planet_model_kernel
from planetnav_env.estimation.measurement_kernels import los_basis_kernel
from planetnav_env.registration import ENV_IDS
from planetnav_env.sensors import pulsar as psr

ENV_ID = "planetnav/MarsApproach-Tasking-v0"
TS = 3600.0  #: velocity scale [s]: the state is (r [km], v·TS [km]), a well-conditioned information
SLOT_STEPS = 4  #: steps per decision slot: the env's 1000-s X-ray integration needs 4 steps of 300 s
PASS_H, DAY_H = 8.0, 24.0  #: DSN pass length and period [h] (stated choice, docs/operations.md §4)
SLEW_H = 180.0 / 3600.0  #: slew back to Earth after a look ending in a pass [h] (env wheel model, §3.1)
DEADLINES_BEFORE_CA_H = (24.0, 2.0)  #: CA − 24 h (last TCM, S11) and CA − 2 h (episode end)
STAY, MARS, CRAB, B1937 = 0, 1, 2, 3
ARCSEC = math.pi / 648000.0
NAMES = "SMCB"


# ----------------------------------------------------------------------------------------------------
# The environment's numbers
# ----------------------------------------------------------------------------------------------------
def env_numbers() -> dict:
    """The numbers of `MarsApproach-Tasking-v0` the model uses, read from the env's own config and params."""
    cfg = EnvConfig.from_dict(ENV_IDS[ENV_ID])
    plan = ChannelPlan("mars", cfg.planets, PERTURBERS, True)
    prm = build_params(cfg, plan, body("mars").gm, np.array([body(b).gm for b in PERTURBERS]))
    s = prm.scalars[0]
    return {
        "step_s": cfg.step_s,
        "episode_steps": cfg.episode_steps,
        "end_before_ca_h": cfg.approach_end_before_ca_h,
        "kind": int(s["kind"]),
        "sig_dir": float(s["sig_dir"]),
        "sig_size": float(s["sig_size"]),
        "alpha_max": float(s["alpha_max"]),
        "cam_sun_excl_rad": math.radians(cfg.camera.sun_exclusion_deg),
        "diameter": 2.0 * float(prm.radii[0]),
        "pulsars": cfg.pulsars,
        "psr": np.array(prm.psr),  # (2, 5): direction, lambda [km], phase sigma [cycles]
        "int_s": float(s["psr_int_s"]),
        "ambig_k": float(s["ambig_k"]),
        "detector": cfg.detector,
        "sigma_pos0": cfg.filter.sigma_pos0,
        "sigma_vel0": cfg.filter.sigma_vel0,
        "accel_psd": cfg.filter.accel_psd,
    }


# ----------------------------------------------------------------------------------------------------
# One geometry: per-slot information of each action, deadline maps, pass costs
# ----------------------------------------------------------------------------------------------------
def step_stms(scn: MarsApproach, n_sub: int = 5) -> np.ndarray:
    """(K, 6, 6) transition matrices of every grid step [unscaled], central differences of RK4 on the env's
    force model (n_sub sub-steps per step)."""
    x = scn.x_true[:-1]
    k = x.shape[0]
    eps = np.array([1.0, 1.0, 1.0, 1e-5, 1e-5, 1e-5])
    pert = np.concatenate([np.eye(6) * eps, -np.eye(6) * eps])  # (12, 6)
    y = (x[:, None, :] + pert[None]).reshape(-1, 6)
    t = np.repeat(scn.t[:-1], 12)
    h = scn.dt / n_sub
    for _ in range(n_sub):
        k1 = scn.model.derivative(y, scn.perturber_positions(t))
        k2 = scn.model.derivative(y + 0.5 * h * k1, scn.perturber_positions(t + 0.5 * h))
        k3 = scn.model.derivative(y + 0.5 * h * k2, scn.perturber_positions(t + 0.5 * h))
        k4 = scn.model.derivative(y + h * k3, scn.perturber_positions(t + h))
        y = y + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        t = t + h
    y = y.reshape(k, 12, 6)
    return np.transpose((y[:, :6] - y[:, 6:]) / (2.0 * eps[None, :, None]), (0, 2, 1))


class Problem:
    """What a schedule's J needs, per 20-min slot: the slot's transition ``phi`` and process noise ``q``
    (scaled state), the information ``info[s, a]`` of action a mapped to the slot's end, the gated action's
    row ``b_row`` (its phase is used only if ``sqrt(b P b + r_b) < gate``), the prior ``p0``, the deadline
    maps ``maps`` (m x n, applied at the deadline) and ``ma``/``qa`` (from each slot's end to each deadline,
    for the greedy's prediction), the pass hours ``cost_h`` and slew-back hours ``slew_h``."""

    n_slots: int
    phi: np.ndarray
    q: np.ndarray
    info: np.ndarray
    gated: int
    b_row: np.ndarray
    r_b: float
    ok_b: np.ndarray
    gate: float
    p0: np.ndarray
    maps: np.ndarray
    dl_slots: np.ndarray
    ma: np.ndarray
    qa: np.ndarray
    cost_h: np.ndarray
    slew_h: np.ndarray

    def packed(self) -> tuple:
        return (
            self.phi,
            self.q,
            self.info,
            self.b_row,
            self.ok_b,
            self.p0,
            self.maps,
            self.dl_slots,
            self.ma,
            self.qa,
            self.cost_h,
            self.slew_h,
        )

    def finish(self) -> None:
        """``ma[s, k]`` = maps[k] times the transition from the end of slot s to deadline k, ``qa[s, k]`` the
        trace of the mapped process noise over that interval (backward recursion)."""
        nd, m, n = self.maps.shape
        self.ma = np.zeros((self.n_slots, nd, m, n))
        self.qa = np.zeros((self.n_slots, nd))
        for k in range(nd):
            e = self.dl_slots[k] - 1
            a = self.maps[k].copy()
            qk = 0.0
            self.ma[e, k] = a
            for s in range(e - 1, -1, -1):
                qk += np.trace(a @ self.q[s + 1] @ a.T)
                a = a @ self.phi[s + 1]
                self.ma[s, k] = a
                self.qa[s, k] = qk


class Geometry(Problem):
    """Scenario B on one approach (see the module docstring), one pass phase."""

    def __init__(
        self, ca_tdb: float, pass_phase_h: float, env: dict, mapping: str, pass_h: float = PASS_H
    ) -> None:
        key = (ca_tdb, mapping)
        if key not in _TRAJECTORIES:
            self._trajectory(ca_tdb, env, mapping)
            _TRAJECTORIES[key] = dict(self.__dict__)
        self.__dict__.update(_TRAJECTORIES[key])
        # Passes: hours of each slot inside a pass, and the slew back when a slot starts inside one
        slot_h = SLOT_STEPS * self.step_s / 3600.0
        t_start = np.arange(self.n_slots) * slot_h
        self.cost_h = np.array([_pass_overlap(t, t + slot_h, pass_phase_h, pass_h) for t in t_start])
        self.slew_h = np.array(
            [SLEW_H if _pass_overlap(t, t + 1e-6, pass_phase_h, pass_h) > 0 else 0.0 for t in t_start]
        )

    def _trajectory(self, ca_tdb: float, env: dict, mapping: str) -> None:
        step = env["step_s"]
        n_ep = env["episode_steps"]
        dur_h = n_ep * step / 3600.0 + env["end_before_ca_h"]
        scn = MarsApproach(ApproachConfig(closest_approach_tdb=ca_tdb, duration_h=dur_h, dt_s=step))
        d = np.array([1.0, 1.0, 1.0, TS, TS, TS])
        phi = step_stms(scn) * d[None, :, None] / d[None, None, :]  # scaled: D Phi D^-1
        q_step = process_noise(step, env["accel_psd"]) * d[:, None] * d[None, :]
        k_all = phi.shape[0]
        n_slots = n_ep // SLOT_STEPS
        self.n_slots = n_slots
        x = scn.x_true
        sun_rel = -scn.mars_helio  # Sun relative to Mars [km]
        h = np.empty(3)
        jac = np.empty((3, 6))
        rcov = np.empty((3, 3))
        basis = np.zeros((2, 3))
        planet = np.zeros(3)
        mars_ok = np.zeros(n_ep + 1, bool)
        mars_info = np.zeros((n_ep + 1, 6, 6))  # per grid index: one image's H^T R^-1 H (scaled, local)
        for i in range(1, n_ep + 1):
            r = x[i, :3]
            to_mars = -r / np.linalg.norm(r)
            to_sun = (sun_rel[i] - r) / np.linalg.norm(sun_rel[i] - r)
            alpha = 2.0 * math.atan(0.5 * env["diameter"] / np.linalg.norm(r))
            if (
                alpha > env["alpha_max"]
                or math.acos(np.clip(to_mars @ to_sun, -1, 1)) < env["cam_sun_excl_rad"]
            ):
                continue
            mars_ok[i] = True
            if env["kind"] >= 2:
                los_basis_kernel(planet, x[i], basis)
            m = planet_model_kernel(
                x[i, :3],
                planet,
                env["diameter"],
                env["kind"],
                env["sig_dir"],
                env["sig_size"],
                basis,
                h,
                jac,
                rcov,
            )
            hs = jac[:m] / d[None, :]
            mars_info[i] = hs.T @ np.linalg.inv(rcov[:m, :m]) @ hs
        r_helio = scn.mars_helio + x[:, :3]
        vis = psr.pulsar_visibility(
            r_helio, env["pulsars"], env["detector"], scn.mars_helio, psr.mars_radius_km()
        ).visible  # (K+1, 2)
        self.phi = np.zeros((n_slots, 6, 6))
        self.q = np.zeros((n_slots, 6, 6))
        self.info = np.zeros((n_slots, 4, 6, 6))
        self.ok_b = np.zeros(n_slots, bool)
        self.n_psr_visible = np.zeros(2, int)
        rows = [np.concatenate([env["psr"][j, :3] / env["psr"][j, 3], np.zeros(3)]) for j in range(2)]
        sig = env["psr"][:, 4]
        for s in range(n_slots):
            i0, i1 = s * SLOT_STEPS + 1, (s + 1) * SLOT_STEPS
            f, qs = np.eye(6), np.zeros((6, 6))
            for i in range(i0, i1 + 1):  # step i takes grid index i-1 to i
                f, qs = phi[i - 1] @ f, phi[i - 1] @ qs @ phi[i - 1].T + q_step
            self.phi[s], self.q[s] = f, qs
            back = np.eye(6)  # transition from grid index i to the slot's end, built backwards
            for i in range(i1, i0 - 1, -1):
                b = np.linalg.inv(back)  # slot end -> index i
                self.info[s, MARS] += b.T @ mars_info[i] @ b
                back = back @ phi[i - 1]
            for j, a in enumerate((CRAB, B1937)):
                if vis[i0 - 1 : i1 + 1, j].all():
                    self.n_psr_visible[j] += 1
                    self.info[s, a] = np.outer(rows[j], rows[j]) / sig[j] ** 2
                    self.ok_b[s] |= a == B1937
        self.gated, self.b_row, self.r_b = B1937, rows[1], float(sig[1] ** 2)
        self.gate = 0.5 / env["ambig_k"]  # sqrt(H P H^T + R) must be below this [cycles]
        self.p0 = np.diag(np.array([env["sigma_pos0"]] * 3 + [env["sigma_vel0"] * TS] * 3) ** 2)
        # Deadlines: grid index, slots before it, local map to CA
        ca_index = k_all
        self.dl_index = np.array([ca_index - round(hb * 3600.0 / step) for hb in DEADLINES_BEFORE_CA_H])
        self.dl_slots = self.dl_index // SLOT_STEPS
        maps = []
        for idx in self.dl_index:
            t_go = (ca_index - idx) * step / TS
            if mapping == "coasted":
                maps.append(np.hstack([np.eye(3), t_go * np.eye(3)]))
            else:
                f = np.eye(6)
                for i in range(idx, ca_index):
                    f = phi[i] @ f
                maps.append(f[:3])
        self.maps = np.array(maps)
        self.t_go_s = (ca_index - self.dl_index) * step
        self.mapping = mapping
        self.mars_ok = mars_ok
        self.step_s = step
        self.finish()


#: Trajectory-dependent parts of a Geometry by (CA epoch, mapping): `--geometry env` builds one.
_TRAJECTORIES: dict[tuple[float, str], dict] = {}


def _pass_overlap(a: float, b: float, phase_h: float, pass_h: float = PASS_H) -> float:
    """Hours of [a, b) [h from the episode start] inside the passes [phase + 24 k, phase + 24 k + pass_h)."""
    tot = 0.0
    for k in range(-2, 8):
        lo = phase_h + DAY_H * k
        tot += max(0.0, min(b, lo + pass_h) - max(a, lo))
    return tot


# ----------------------------------------------------------------------------------------------------
# Schedule objective (compiled): a covariance pass over the slots, the gate on the covariance before it
# ----------------------------------------------------------------------------------------------------
@njit(cache=True)
def _slot(p, s, a, pb, gated, r_b, gate, out):  # pragma: no cover - compiled
    """out = the covariance at the end of slot s after action a from p at its start; returns True when
    the gated action's phase was skipped (ambiguity rule)."""
    phi, q, info, b_row, ok_b = pb[0], pb[1], pb[2], pb[3], pb[4]
    f = np.ascontiguousarray(phi[s])
    out[:] = f @ p @ f.T + q[s]
    if a == 0:
        return False
    if a == gated:
        if not ok_b[s]:
            return False
        if math.sqrt(r_b + b_row @ out @ b_row) >= gate:
            return True
    # (P^-1 + J)^-1 = P (I + J P)^-1, symmetrised
    upd = out @ np.linalg.inv(np.eye(out.shape[0]) + info[s, a] @ out)
    out[:] = 0.5 * (upd + upd.T)
    return False


@njit(cache=True)
def _proj(p, m):  # pragma: no cover - compiled
    """trace(M P M^T)."""
    tr = 0.0
    for a in range(m.shape[0]):
        for i in range(p.shape[0]):
            mi = m[a, i]
            if mi == 0.0:
                continue
            for j in range(p.shape[0]):
                tr += mi * p[i, j] * m[a, j]
    return tr


@njit(cache=True)
def _forward(sched, s0, s1, pst, sig, pb, gated, r_b, gate):  # pragma: no cover - compiled
    """Slots s0..s1-1 of ``sched`` from pst[s0]: writes pst[s+1] and the sigma [km] of each deadline
    reached; returns the skipped phases."""
    maps, dl = pb[6], pb[7]
    skipped = 0
    for s in range(s0, s1):
        if _slot(pst[s], s, sched[s], pb, gated, r_b, gate, pst[s + 1]):
            skipped += 1
        for k in range(dl.shape[0]):
            if dl[k] - 1 == s:
                sig[k] = math.sqrt(_proj(pst[s + 1], maps[k]))
    return skipped


@njit(cache=True)
def _hours(sched, pb):  # pragma: no cover - compiled
    cost_h, slew_h = pb[10], pb[11]
    n = sched.shape[0]
    h = 0.0
    for s in range(n):
        if sched[s] != 0:
            h += cost_h[s]
            if s + 1 < n and sched[s + 1] == 0:
                h += slew_h[s + 1]
    return h


@njit(cache=True)
def schedule_j(sched, pb, gated, r_b, gate, w):  # pragma: no cover - compiled
    """(J [km], sigma per deadline [km], pass hours lost, skipped phases) of ``sched``."""
    n = sched.shape[0]
    nd = pb[7].shape[0]
    pst = np.empty((n + 1,) + pb[5].shape)
    pst[0] = pb[5]
    sig = np.zeros(nd)
    skipped = _forward(sched, 0, n, pst, sig, pb, gated, r_b, gate)
    h = _hours(sched, pb)
    return sig.sum() + w * h, sig, h, skipped


@njit(cache=True)
def descend(sched, pb, gated, r_b, gate, w, max_sweeps):  # pragma: no cover - compiled
    """Coordinate descent in place, first improvement: every slot's action, then shifts of a look by
    ±1, 2, 4, 8 slots (a swap with the slot there), until a sweep improves nothing. Each candidate is
    evaluated from the first slot it changes (the covariances before it are kept). Returns J."""
    n = sched.shape[0]
    nd = pb[7].shape[0]
    pst = np.empty((n + 1,) + pb[5].shape)
    pst[0] = pb[5]
    sig = np.zeros(nd)
    _forward(sched, 0, n, pst, sig, pb, gated, r_b, gate)
    best = sig.sum() + w * _hours(sched, pb)
    valid = n  # pst[0..valid] belong to the accepted schedule
    shifts = np.array([1, 2, 4, 8, -1, -2, -4, -8])
    n_act = pb[2].shape[1]
    for _ in range(max_sweeps):
        improved = False
        for s in range(n):
            if valid < s:
                _forward(sched, valid, s, pst, sig, pb, gated, r_b, gate)
                valid = s
            old = sched[s]
            for a in range(n_act):
                if a == old:
                    continue
                sched[s] = a
                sc = sig.copy()
                _forward(sched, s, n, pst, sc, pb, gated, r_b, gate)
                j = sc.sum() + w * _hours(sched, pb)
                if j < best - 1e-9:
                    best, old, sig, valid, improved = j, a, sc, n, True
                else:
                    sched[s] = old
                    valid = s
        for s in range(n):
            if sched[s] == 0:
                continue
            for d in shifts:
                t = s + d
                if t < 0 or t >= n or sched[t] == sched[s]:
                    continue
                lo = min(s, t)
                if valid < lo:
                    _forward(sched, valid, lo, pst, sig, pb, gated, r_b, gate)
                    valid = lo
                sched[s], sched[t] = sched[t], sched[s]
                sc = sig.copy()
                _forward(sched, lo, n, pst, sc, pb, gated, r_b, gate)
                j = sc.sum() + w * _hours(sched, pb)
                if j < best - 1e-9:
                    best, sig, valid, improved = j, sc, n, True
                    break
                sched[s], sched[t] = sched[t], sched[s]
                valid = lo
        if not improved:
            break
    return best


@njit(cache=True)
def greedy_schedule(pb, gated, r_b, gate, w, theta, session):  # pragma: no cover - compiled
    """The deadline- and cost-aware greedy: at each free slot score each target by the predicted reduction
    of the remaining deadlines' sigma [km] after a session of ``session`` slots on it (nothing measured
    after it; a gated phase that fails the rule scores nothing); start the best session when its score
    exceeds ``theta * w * price`` (price: its pass hours and the slew back), and finish it."""
    info, p0, maps, dl, ma, qa, cost_h, slew_h = pb[2], pb[5], pb[6], pb[7], pb[8], pb[9], pb[10], pb[11]
    n = info.shape[0]
    n_act = info.shape[1]
    nd = dl.shape[0]
    sched = np.zeros(n, np.int64)
    p = p0.copy()
    a_buf = np.empty_like(p0)
    b_buf = np.empty_like(p0)
    s = 0
    while s < n and s < dl[nd - 1]:
        e = min(n, s + session)
        scores = np.zeros(n_act)
        for a in range(n_act):
            a_buf[:] = p
            tot = 0.0
            done = np.zeros(nd, np.bool_)
            for u in range(s, e):
                _slot(a_buf, u, a, pb, gated, r_b, gate, b_buf)
                a_buf[:] = b_buf
                for k in range(nd):
                    if dl[k] - 1 == u:
                        tot += math.sqrt(_proj(a_buf, maps[k]))
                        done[k] = True
            for k in range(nd):
                if not done[k] and dl[k] - 1 > e - 1:
                    tot += math.sqrt(_proj(a_buf, ma[e - 1, k]) + qa[e - 1, k])
            scores[a] = tot
        best_a = 0
        best_score = 0.0
        for a in range(1, n_act):
            if scores[0] - scores[a] > best_score:
                best_score = scores[0] - scores[a]
                best_a = a
        price = 0.0
        for u in range(s, e):
            price += cost_h[u]
        if e < n:
            price += slew_h[e]
        go = best_a > 0 and (price <= 0.0 or w == 0.0 or best_score > theta * w * price)
        act = best_a if go else 0
        last = e if go else s + 1
        for u in range(s, last):
            sched[u] = act
            _slot(p, u, act, pb, gated, r_b, gate, b_buf)
            p[:] = b_buf
        s = last
    return sched


def periodic_schedule(
    n: int, period: int, session: int, phase: int, cycle: tuple[int, ...], avoid: bool, g
) -> np.ndarray:
    """Slot s looks when (s − phase) mod period < session; session m looks at cycle[m mod len]; with
    ``avoid`` a slot touching a pass stays at Earth."""
    s = np.arange(n)
    on = ((s - phase) % period < session) & (s >= phase)
    tgt = np.array(cycle)[((s - phase) // period) % len(cycle)]
    out = np.where(on, tgt, STAY)
    if avoid:
        out = np.where(g.cost_h > 0, STAY, out)
    return out.astype(np.int64)


def periodic_grid(periods: tuple[int, ...], sessions: tuple[int, ...]) -> list[tuple]:
    """Every period and session (session < period), three phases, every cycle of distinct targets, with
    and without skipping pass slots; and a look at every slot with every cycle of length <= 4 (repeats
    allowed, so that the mix of targets is a parameter too)."""
    cycles = [c for r in (1, 2, 3) for c in itertools.permutations((1, 2, 3), r)]
    out = [
        (1, 1, 0, c, avoid)
        for r in (1, 2, 3, 4)
        for c in itertools.product((1, 2, 3), repeat=r)
        for avoid in (False, True)
    ]
    for period in periods:
        for session in sessions:
            if session >= period:
                continue
            for phase in sorted({0, period // 3, (2 * period) // 3}):
                for cycle in cycles:
                    for avoid in (False, True):
                        out.append((period, session, phase, cycle, avoid))
    return out


def evaluate(g: Problem, sched: np.ndarray, w: float) -> tuple:
    """(J [km], sigma per deadline [km], hours lost, skipped phases) of ``sched`` on ``g``."""
    return schedule_j(np.asarray(sched, np.int64), g.packed(), g.gated, g.r_b, g.gate, w)


# ----------------------------------------------------------------------------------------------------
# Statistics and the run
# ----------------------------------------------------------------------------------------------------
def mean_ci(x: np.ndarray) -> tuple[float, float]:
    """Mean and the half-width of its 95 % t-interval."""
    from scipy import stats

    x = np.asarray(x, float)
    if x.size < 2:
        return float(x.mean()), float("nan")
    return float(x.mean()), float(stats.t.ppf(0.975, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))


def draw_geometries(
    n: int, seed: int, kind: str, env: dict, mapping: str, pass_h: float = PASS_H
) -> list[Geometry]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        off_d = rng.uniform(-45.0, 45.0) if kind == "family" else 0.0
        phase = rng.uniform(0.0, DAY_H)
        out.append(Geometry(DEFAULT_CLOSEST_APPROACH_TDB + off_d * 86400.0, phase, env, mapping, pass_h))
    return out


def _pct(diff: np.ndarray, ref: np.ndarray) -> str:
    """Paired mean difference as % of the reference's mean, with its 95 % interval."""
    dm, dh = mean_ci(diff)
    r = ref.mean()
    return f"{100 * dm / r:+.1f} % [{100 * (dm - dh) / r:+.1f}, {100 * (dm + dh) / r:+.1f}]"


def sched_str(s: np.ndarray) -> str:
    return "".join(NAMES[a] for a in s)


def run(
    label: str,
    tune: list[Problem],
    held: list[Problem],
    args: argparse.Namespace,
    grid: list[tuple],
    names: str,
    dl_names: list[str],
    cost_name: str,
) -> None:
    """Tune the rules on ``tune``, then compare periodic, greedy and the optimum on ``held``, paired, for
    each weight; print one table per weight."""
    for w in args.weights:
        t1 = time.time()
        pj = np.array([[evaluate(g, periodic_schedule(g.n_slots, *p, g), w)[0] for g in tune] for p in grid])
        ip = int(np.argmin(pj.mean(1)))
        best_p = grid[ip]
        gj = {}
        for theta in args.thetas if w > 0 else (0.0,):
            for session in (1, 3):
                gj[(theta, session)] = np.mean(
                    [evaluate(g, _greedy(g, w, theta, session), w)[0] for g in tune]
                )
        best_g = min(gj, key=gj.get)
        res: dict[str, list] = {k: [] for k in ("periodic", "greedy", "optimum", "always", "stay", "bound")}
        cache: dict[tuple, tuple] = {}
        for g in held:
            sp = periodic_schedule(g.n_slots, *best_p, g)
            sg = _greedy(g, w, *best_g)
            key = (id(g.info), g.cost_h.tobytes()) if w > 0 else (id(g.info),)
            if key not in cache:  # with w = 0 the pass phase does not matter: one search per trajectory
                best_j, best_s = math.inf, None
                rng = np.random.default_rng(args.seed + 7)
                n_act = g.info.shape[1]
                randoms = [rng.integers(0, n_act, g.n_slots) for _ in range(args.restarts)]
                for start in (sp, sg, np.zeros(g.n_slots, np.int64), *randoms):
                    sc = start.copy()
                    j = descend(sc, g.packed(), g.gated, g.r_b, g.gate, w, args.sweeps)
                    if j < best_j:
                        best_j, best_s = j, sc.copy()
                cache[key] = best_s
            always = periodic_schedule(g.n_slots, 1, 1, 0, (1, 2, 3), False, g)
            lb_j, lb_sig = lower_bound(g)
            res["bound"].append((lb_j, *lb_sig, 0.0, math.nan, 0, None))
            for name, sc in (
                ("periodic", sp),
                ("greedy", sg),
                ("optimum", cache[key]),
                ("always", always),
                ("stay", np.zeros_like(sp)),
            ):
                j, sig, hours, skipped = evaluate(g, sc, w)
                res[name].append((j, *sig, hours, (sc != STAY).mean(), skipped, sc))
        jp = np.array([r[0] for r in res["periodic"]])
        jg = np.array([r[0] for r in res["greedy"]])
        rule = "periodic" if jp.mean() <= jg.mean() else "greedy"
        jr = jp if rule == "periodic" else jg
        nd = len(dl_names)
        print(f"\n== {label}, w = {w:g} km per {cost_name} ({time.time() - t1:.0f} s) ==")
        print(
            f"tuned periodic: period {best_p[0]} slots, session {best_p[1]}, phase {best_p[2]}, cycle "
            f"{'-'.join(names[c] for c in best_p[3])}, skip pass slots {best_p[4]} "
            f"(tuning J {pj[ip].mean():.3f}); tuned greedy: theta {best_g[0]}, session {best_g[1]} slots "
            f"(tuning J {gj[best_g]:.3f})"
        )
        head = " | ".join(f"sigma({d}) km" for d in dl_names)
        print(
            f"| agent | J km [95 % CI] | {head} | {cost_name} | look fraction | skipped | "
            "vs best rule, % of its J [95 % CI] |"
        )
        print("|---|---|" + "---|" * nd + "---|---|---|---|")
        for name, rows in res.items():
            j = np.array([r[0] for r in rows])
            det = np.array([r[1 : nd + 4] for r in rows], float)
            m, h = mean_ci(j)
            rel = "(best rule)" if name == rule else _pct(j - jr, jr)
            sig = " | ".join(f"{v:.3f}" for v in det[:, :nd].mean(0))
            print(
                f"| {name} | {m:.3f} [{m - h:.3f}, {m + h:.3f}] | {sig} | {det[:, nd].mean():.2f} | "
                f"{det[:, nd + 1].mean():.3f} | {det[:, nd + 2].mean():.1f} | {rel} |"
            )
        if args.show:
            print(f"  schedules on the first held-out ({names[0]} stay, then targets; ^ pass slot):")
            for name in ("periodic", "greedy", "optimum"):
                print(f"  {name:9s}", "".join(names[a] for a in res[name][0][-1]))
            print("           ", "".join("^" if c > 0 else " " for c in held[0].cost_h))


def run_b(args: argparse.Namespace) -> None:
    env = env_numbers()
    t0 = time.time()
    print(
        f"env {ENV_ID}: step {env['step_s']:.0f} s, {env['episode_steps']} steps, "
        f"ends CA-{env['end_before_ca_h']} h; camera sig_dir {env['sig_dir'] / ARCSEC:.2f} arcsec, "
        f"sig_size {env['sig_size']:.2e} rad (kind {env['kind']}); pulsars {env['pulsars']} lambda "
        f"{env['psr'][:, 3].round(1)} km, range sigma {(env['psr'][:, 3] * env['psr'][:, 4]).round(3)} km, "
        f"integration {env['int_s']:.0f} s; prior {env['sigma_pos0']} km, {env['sigma_vel0'] * 1e3} m/s; "
        f"process noise PSD {env['accel_psd']} km^2/s^3"
    )
    tune = draw_geometries(args.tuning, args.seed, args.geometry, env, args.mapping, args.pass_hours)
    held = draw_geometries(args.held_out, args.seed + 1000, args.geometry, env, args.mapping, args.pass_hours)
    g = held[0]
    print(
        f"geometry {args.geometry}, mapping {args.mapping}, passes {args.pass_hours:g} h per 24 h: "
        f"{len(tune)} tuning, {len(held)} held-out; "
        f"{g.n_slots} slots of {SLOT_STEPS * env['step_s'] / 60:.0f} min; deadlines at grid "
        f"{g.dl_index.tolist()}; first held-out: Mars imageable {g.mars_ok.sum()} steps, pulsar slots "
        f"visible {g.n_psr_visible.tolist()} (built in {time.time() - t0:.1f} s)"
    )
    if args.mapping == "coasted":
        # The deadline quantity is the env's own: sigma^2 = coasted_position_trace(P, t_go) (unscaled P).
        sc = periodic_schedule(g.n_slots, 1, 1, 0, (1, 2, 3), False, g)
        pst = np.empty((g.n_slots + 1, 6, 6))
        pst[0] = g.p0
        sig = np.zeros(len(g.dl_slots))
        _forward(sc, 0, g.n_slots, pst, sig, g.packed(), g.gated, g.r_b, g.gate)
        d = np.array([1.0, 1.0, 1.0, TS, TS, TS])
        env_sig = [
            math.sqrt(coasted_position_trace(pst[k] / d[:, None] / d[None, :], float(t)))
            for k, t in zip(g.dl_slots, g.t_go_s, strict=True)
        ]
        print(
            f"check: deadline sigma {sig.round(6).tolist()} km, env coasted_position_trace "
            f"{np.round(env_sig, 6).tolist()} km"
        )
    grid = periodic_grid((2, 3, 4, 6, 9, 12, 18, 36, 72), (1, 2, 3, 6, 12))
    run("scenario B", tune, held, args, grid, NAMES, ["CA-24h", "CA-2h"], "pass h lost")


class APrime(Problem):
    """A′ (`Coast-Downlink-TCM-v0`): §5's 2-D free-flight model without thrust. 42 slots of 12 h over
    21 d; a slot either stays Earth-pointed or holds one 2-h session of 120 images of one of three
    beacons (direction uniform, range 0.2-1.2 AU), the env's camera 1-sigma per image (3.81″) over 120;
    prior and process noise the cruise env's (EnvConfig().filter: 1000 km, 1 m/s, PSD 1e-20);
    deadlines E-14, E-5, E-1.5 d coasted to E; cost 2.1 h of downlink per session (2 h + two 180-s slews)."""

    def __init__(self, rng: np.random.Generator, sig_dir: float, filt) -> None:
        ts = 86400.0  # velocity scale [s]
        slot_s, self.n_slots = 12 * 3600.0, 42
        f = np.eye(4)
        f[0, 2] = f[1, 3] = slot_s / ts
        self.phi = np.repeat(f[None], self.n_slots, 0)
        d = np.array([1.0, 1.0, ts, ts])
        q3 = process_noise(slot_s, filt.accel_psd)[np.ix_([0, 1, 3, 4], [0, 1, 3, 4])]
        self.q = np.repeat((q3 * d[:, None] * d[None, :])[None], self.n_slots, 0)
        self.info = np.zeros((self.n_slots, 4, 4, 4))
        for b in range(1, 4):
            ang = rng.uniform(0.0, 2.0 * math.pi)
            rho = rng.uniform(0.2, 1.2) * 1.495978707e8
            hrow = np.array([-math.sin(ang), math.cos(ang), 0.0, 0.0]) / rho
            self.info[:, b] = np.outer(hrow, hrow) / (sig_dir**2 / 120.0)
        self.gated, self.b_row, self.r_b, self.gate = -1, np.zeros(4), 0.0, 1.0
        self.ok_b = np.zeros(self.n_slots, bool)
        p, v = filt.sigma_pos0, filt.sigma_vel0 * ts
        self.p0 = np.diag(np.array([p, p, v, v]) ** 2)
        e_d = 21.0
        self.dl_slots = np.array([round((e_d - t) * 2) for t in (14.0, 5.0, 1.5)])
        self.maps = np.array(
            [np.hstack([np.eye(2), (t * 86400.0 / ts) * np.eye(2)]) for t in (14.0, 5.0, 1.5)]
        )
        self.cost_h = np.full(self.n_slots, 2.1)
        self.slew_h = np.zeros(self.n_slots)
        self.finish()


def run_a_prime(args: argparse.Namespace) -> None:
    env = env_numbers()
    filt = EnvConfig().filter  # the cruise env's prior and process noise
    psd = filt.accel_psd
    rng_t, rng_h = np.random.default_rng(args.seed), np.random.default_rng(args.seed + 1000)
    tune = [APrime(rng_t, env["sig_dir"], filt) for _ in range(args.tuning)]
    held = [APrime(rng_h, env["sig_dir"], filt) for _ in range(args.held_out)]
    print(
        f"A′: 2-D coast, 42 slots of 12 h, 3 beacons, camera {env['sig_dir'] / ARCSEC:.2f} arcsec "
        f"/ sqrt(120) per session, prior {filt.sigma_pos0} km / {filt.sigma_vel0 * 1e3} m/s, "
        f"process noise PSD {psd} km^2/s^3; "
        f"{len(tune)} tuning, {len(held)} held-out geometries"
    )
    grid = periodic_grid((2, 3, 4, 6, 8, 10, 14), (1, 2))
    run("A′", tune, held, args, grid, "S123", ["E-14d", "E-5d", "E-1.5d"], "downlink h lost")


def lower_bound(g: Problem) -> tuple[float, np.ndarray]:
    """A lower bound on any schedule's J [km] at any w: every target's information in every slot at once,
    ungated (more information never raises a deadline's sigma, and it only lets a gated phase in
    sooner), at no cost. Returns J and the sigma per deadline [km]."""
    b = copy.copy(g)
    b.info = g.info.copy()
    b.info[:, 1] = g.info[:, 1:].sum(axis=1)
    b.gated = -1
    j, sig, _, _ = evaluate(b, np.ones(g.n_slots, np.int64), 0.0)
    return float(j), sig


def _greedy(g: Problem, w: float, theta: float, session: int) -> np.ndarray:
    return greedy_schedule(g.packed(), g.gated, g.r_b, g.gate, w, theta, session)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scenario", choices=("b", "a-prime"), default="b")
    ap.add_argument("--geometry", choices=("env", "family"), default="env")
    ap.add_argument("--mapping", choices=("coasted", "stm"), default="coasted")
    ap.add_argument(
        "--weights",
        type=float,
        nargs="+",
        default=None,
        help="km per hour lost; default 0 0.3 1 3 (B), 0 30 90 270 (A′)",
    )
    ap.add_argument(
        "--thetas",
        type=float,
        nargs="+",
        default=[0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0, math.inf],
    )
    ap.add_argument("--tuning", type=int, default=8)
    ap.add_argument("--held-out", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sweeps", type=int, default=20)
    ap.add_argument(
        "--pass-hours", type=float, default=PASS_H, help="B: pass length per 24 h [h]; 24: every hour costs"
    )
    ap.add_argument("--restarts", type=int, default=0, help="random starting schedules for the search")
    ap.add_argument("--show", action="store_true", help="print the first held-out geometry's schedules")
    args = ap.parse_args()
    if not 0.0 < args.pass_hours <= DAY_H:
        ap.error(f"--pass-hours must be in (0, 24], got {args.pass_hours}")
    if args.restarts < 0:
        ap.error(f"--restarts must be >= 0, got {args.restarts}")
    for name in ("tuning", "held_out", "sweeps"):
        if getattr(args, name) < 1:
            ap.error(f"--{name.replace('_', '-')} must be >= 1, got {getattr(args, name)}")
    if args.weights is None:
        args.weights = [0.0, 0.3, 1.0, 3.0] if args.scenario == "b" else [0.0, 30.0, 90.0, 270.0]
    if any(w < 0 or not math.isfinite(w) for w in args.weights):
        ap.error(f"--weights must be finite and >= 0, got {args.weights}")
    if args.scenario == "b":
        run_b(args)
    else:
        run_a_prime(args)


if __name__ == "__main__":
    main()
