"""PlanetNavEnv: autonomous interplanetary navigation with a star camera, as a Gymnasium environment.

One step (``EnvConfig.step_s``, default 60 s):

1. the action is validated and decoded (target planet and/or wheel torque);
2. the attitude advances ``step_s / attitude_substep_s`` RK4 sub-steps, the wheels applying the PD
   law's torque toward the chosen planet (``target``), the agent's torque (``torque``), or both
   (``target+torque``), clipped by the wheel torque and momentum limits;
3. the truth orbit advances one RK4 step; the EKF predicts;
4. the star tracker fixes the attitude (q-method on the stars in its field, ``star_tracker``);
5. the camera measures the planet it is pointed at if that planet is visible (field of view, Sun
   exclusion, occultation, detection threshold), turning the body-frame line of sight into the
   inertial frame with the *star tracker's* attitude, and the EKF updates (innovations beyond the
   chi-square gate are rejected and counted).

The agent never reads the truth: observations are built from the filter's estimate and covariance,
the star tracker's attitude, the reported rates, wheel momenta and the ephemeris. The default reward
uses the true error (a privileged training signal; ``reward="covariance"`` is computable on board).

Simplification: the PD law runs on the true attitude inside the sub-steps (its error, a few arcsec
from the star tracker, is far below what changes a slew); the target direction it tracks comes from
the *estimated* position.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from numba import njit

from planetnav_env import quaternion as qt
from planetnav_env.attitude.pointing import frame_kernel, substeps_kernel
from planetnav_env.bodies import AU_KM, body
from planetnav_env.config import EnvConfig
from planetnav_env.dynamics.attitude import (
    dcm_body_to_inertial_kernel,
    load_state_kernel,
    store_state_kernel,
)
from planetnav_env.dynamics.orbit import GravityModel
from planetnav_env.ephemeris import DEEphemeris
from planetnav_env.errors import InvalidParameterError, NonFiniteError, NotVisibleError
from planetnav_env.estimation.fast import KIND_CODES, SingleEKF, rk4_batch_kernel
from planetnav_env.estimation.measurements import MeasurementModel
from planetnav_env.scenarios import approach_episode, draw_episode
from planetnav_env.sensors import camera as cam
from planetnav_env.sensors import pulsar as psr
from planetnav_env.sensors.star_tracker import StarTrackerConfig, estimate_attitude

_NONE3 = np.zeros((0, 3))
_ZERO3 = np.zeros(3)
_NO_MU = np.zeros(0)
_DEG = np.pi / 180.0
ARCSEC = np.pi / 648_000.0

_REASONS = {int(v): v.name.lower() for v in cam.VisibilityReason}

#: Per-target observation block (planets; pulsars use the same width): see PlanetNavEnv.
PLANET_FEATURES = 7


@njit(cache=True)
def _attitude_substeps(
    q, w, h, use_pd, direction, roll_ref, u_bias, n, dt, jm, jinv, tau_max, h_max, k_a, k_w, u_last
):  # pragma: no cover - compiled
    """Load the state, build the PD reference frame, run the pointing module's sub-step loop, store.

    Returns False when the state became non-finite or the direction is zero.
    """
    y = np.empty(7)
    frame = np.empty((3, 3))
    if not load_state_kernel(q, w, y):
        return False
    if use_pd and not frame_kernel(direction, roll_ref, frame):
        return False
    substeps_kernel(
        y, h, use_pd, frame, u_bias, _ZERO3, n, dt, jm, jinv, tau_max, h_max, k_a, k_w,
        np.empty((8, 7)), np.empty((3, 3)), np.empty((3, 3)), np.empty(3), u_last,
    )  # fmt: skip
    return store_state_kernel(y, h, q, w, h)


@njit(cache=True)
def _measurement_vector(los_body, alpha, q_est, planet, x_est, kind, z, basis):  # pragma: no cover - compiled
    """Filter measurement z from a body-frame line of sight rotated by the star-tracker attitude.

    kind 0/1: (theta, phi[, alpha]); kind 2/3: the LOS projected on a basis orthogonal to the
    *predicted* line of sight (written into ``basis``, as measurements.los_basis builds it).
    Returns the dimension m.
    """
    r = np.empty((3, 3))
    dcm_body_to_inertial_kernel(q_est[0], q_est[1], q_est[2], q_est[3], r)
    u = np.empty(3)
    for i in range(3):
        u[i] = r[i, 0] * los_body[0] + r[i, 1] * los_body[1] + r[i, 2] * los_body[2]
    if kind <= 1:
        z[0] = np.arcsin(min(max(u[2], -1.0), 1.0))
        z[1] = np.arctan2(u[1], u[0])
    else:
        d = planet - x_est[:3]
        d = d / np.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        # e1 = d x (axis least aligned with d), e2 = d x e1: the construction of los_basis.
        k = 0
        if abs(d[1]) < abs(d[k]):
            k = 1
        if abs(d[2]) < abs(d[k]):
            k = 2
        ax = np.zeros(3)
        ax[k] = 1.0
        e1 = np.cross(d, ax)
        e1 /= np.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
        e2 = np.cross(d, e1)
        for i in range(3):
            basis[0, i] = e1[i]
            basis[1, i] = e2[i]
        z[0] = e1[0] * u[0] + e1[1] * u[1] + e1[2] * u[2]
        z[1] = e2[0] * u[0] + e2[1] * u[1] + e2[2] * u[2]
    if kind == 1 or kind == 3:
        z[2] = alpha
        return 3
    return 2


@njit(cache=True)
def _planet_geometry(x_est, q_est, p_rr, planets, radii, boresight, out, q_point):  # pragma: no cover
    """Per-planet features from the estimate (see PlanetNavEnv), except the observable flag, and the
    shortest-arc attitudes that would point the boresight at each planet (``q_point``, for that flag).

    out[:, 0:3] direction in body axes, 3 log10(distance / AU), 4 apparent diameter [rad],
    6 log10(position 1-sigma across the line of sight [km]) / 4.
    """
    r = np.empty((3, 3))
    dcm_body_to_inertial_kernel(q_est[0], q_est[1], q_est[2], q_est[3], r)
    tr = p_rr[0, 0] + p_rr[1, 1] + p_rr[2, 2]
    for p in range(planets.shape[0]):
        d0 = planets[p, 0] - x_est[0]
        d1 = planets[p, 1] - x_est[1]
        d2 = planets[p, 2] - x_est[2]
        dist = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        u0, u1, u2 = d0 / dist, d1 / dist, d2 / dist
        for i in range(3):  # R^T u
            out[p, i] = r[0, i] * u0 + r[1, i] * u1 + r[2, i] * u2
        out[p, 3] = np.log10(dist / AU_KM)
        out[p, 4] = 2.0 * np.arcsin(min(radii[p] / dist, 1.0))
        along = (
            u0 * (p_rr[0, 0] * u0 + p_rr[0, 1] * u1 + p_rr[0, 2] * u2)
            + u1 * (p_rr[1, 0] * u0 + p_rr[1, 1] * u1 + p_rr[1, 2] * u2)
            + u2 * (p_rr[2, 0] * u0 + p_rr[2, 1] * u1 + p_rr[2, 2] * u2)
        )
        out[p, 6] = np.log10(np.sqrt(max(tr - along, 1e-12))) / 4.0
        # Shortest arc from the boresight b to u: q = [1 + b.u, b x u] / norm (u never opposite b
        # here: that case takes a perpendicular axis).
        b0, b1, b2 = boresight[0], boresight[1], boresight[2]
        w = 1.0 + b0 * u0 + b1 * u1 + b2 * u2
        c0, c1, c2 = b1 * u2 - b2 * u1, b2 * u0 - b0 * u2, b0 * u1 - b1 * u0
        if w < 1e-12:
            w, c0, c1, c2 = 0.0, -b1, b0, 0.0 if abs(b2) < 0.9 else b0
        nq = np.sqrt(w * w + c0 * c0 + c1 * c1 + c2 * c2)
        q_point[p, 0], q_point[p, 1], q_point[p, 2], q_point[p, 3] = w / nq, c0 / nq, c1 / nq, c2 / nq


@njit(cache=True)
def _spacecraft_block(buf, x, p, q_est, w_meas, h_w, h_max, pos_scale, vel_scale):  # pragma: no cover
    """Observation entries 0-21 (see PlanetNavEnv): estimate, log sigmas, attitude, rates, wheels."""
    for i in range(3):
        buf[i] = x[i] / pos_scale
        buf[3 + i] = x[3 + i] / vel_scale
        buf[6 + i] = np.log10(np.sqrt(max(p[i, i], 1e-30))) / 4.0
        buf[9 + i] = np.log10(np.sqrt(max(p[3 + i, 3 + i], 1e-30)) * 1e3) / 4.0
        buf[16 + i] = w_meas[i] / (np.pi / 180.0)
        buf[19 + i] = h_w[i] / h_max[i]
    for i in range(4):
        buf[12 + i] = q_est[i]


@njit(cache=True)
def _nees(x_est, x_true, p):  # pragma: no cover - compiled
    """e^T P^-1 e by Cholesky (P symmetric positive definite); NaN if the factorisation fails."""
    n = 6
    e = np.empty(n)
    for i in range(n):
        e[i] = x_est[i] - x_true[i]
    lo = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 1):
            acc = p[i, j]
            for k in range(j):
                acc -= lo[i, k] * lo[j, k]
            if i == j:
                if not acc > 0.0:
                    return np.nan
                lo[i, i] = np.sqrt(acc)
            else:
                lo[i, j] = acc / lo[j, j]
    total = 0.0
    y = np.empty(n)
    for i in range(n):  # forward substitution L y = e
        acc = e[i]
        for k in range(i):
            acc -= lo[i, k] * y[k]
        y[i] = acc / lo[i, i]
        total += y[i] * y[i]
    return total


class PlanetNavEnv(gym.Env):
    """Autonomous optical navigation between the planets (see the module docstring for one step).

    Action spaces (``action_mode``)
    -------------------------------
    ============== ======================================== ==========================================
    mode           space                                    meaning
    ============== ======================================== ==========================================
    target         ``Discrete(n_planets)``                  planet index (order of ``planets``); the
                   (``+1`` "camera off" if ``idle_action``)  thesis's PD law slews to it
    torque         ``Box(-1, 1, (3,))``                     wheel torque / torque limit, body axes;
                                                            the camera measures the visible planet
                                                            nearest its boresight
    target+torque  ``Box(-1, 1, (n_planets + 3,))``         ``argmax(a[:n])`` picks the target (PD law
                                                            slews to it); ``a[n:]`` is a residual torque
                                                            (fraction of the limit) added to the PD
                                                            command. A Box because Stable-Baselines3
                                                            rejects Dict and Tuple action spaces.
    ============== ======================================== ==========================================

    Box actions outside [-1, 1] are clipped (SB3 clips to the bounds too); NaN or infinite actions
    raise :class:`~planetnav_env.errors.NonFiniteError`; a discrete action outside its range raises
    :class:`~planetnav_env.errors.InvalidParameterError`. Nothing invalid reaches the physics.

    Observation (``observation="box"``, float32; ``P`` planets, ``Q`` pulsars, ``T = P + Q``)
    ----------------------------------------------------------------------------------------
    ============== ======================================================== ================
    index          content                                                  scale
    ============== ======================================================== ================
    0-2            estimated position relative to the central body (the    / 1 AU (10^6 km on
                   Sun; Mars on approach), ICRF                             approach)
    3-5            estimated velocity                                       / 30 km/s (5)
    6-8            log10 of the filter's position 1-sigma per axis          log10(km) / 4
    9-11           log10 of the filter's velocity 1-sigma per axis          log10(m/s) / 4
    12-15          attitude quaternion from the star tracker (scalar first) -
    16-18          reported body rates                                      deg/s
    19-21          wheel momentum                                           / capacity
    22+7p..28+7p   planet p: estimated direction in body axes (3),          -, log10(AU),
                   log10(estimated distance / AU), estimated apparent       / sigma_alpha,
                   diameter / diameter noise, observable if pointed at      0/1,
                   (Sun exclusion, occultation, size), log10 of the         log10(km) / 4
                   position 1-sigma across its line of sight (what a
                   measurement of it would shrink)
    22+7P+7j..     pulsar j: direction in body axes (3), integration        -, 0..1,
                   progress, log10 predicted phase 1-sigma [cycles],        log10, 0/1,
                   observable (Sun, occultation), log10 of the position     log10(km) / 4
                   1-sigma along its direction
    22+7T..        current target, one-hot (T)                              0/1
    last           elapsed fraction of the episode                          0..1
    ============== ======================================================== ================

    ``observation="dict"`` gives the same quantities under the keys ``position``, ``velocity``,
    ``log_sigma``, ``attitude``, ``rates``, ``wheel_momentum``, ``planets`` (P, 7), ``pulsars``
    (Q, 7; only with pulsars), ``target`` (T,) and ``elapsed`` (1,). :meth:`decode_observation`
    turns either form back into physical units (for rule-based agents).

    Reward, termination, info
    -------------------------
    ``reward="truth"``: ``-|r_est - r_true| / reward_scale_km`` per step (privileged: a real
    spacecraft cannot compute it); ``"covariance"``: ``-sqrt(trace P_rr) / reward_scale_km``. Minus
    ``torque_penalty * |u / u_max|^2`` for commanded torques. The episode *terminates* when the true
    position error exceeds ``divergence_km`` or the filter state becomes non-finite (divergence), and
    is *truncated* after ``episode_steps``. ``info`` holds ``pos_err_km``, ``vel_err_km_s``, ``nees``,
    ``pos_sigma_km``, ``measured``, ``rejected``, ``target``, ``visibility`` (reason), ``slewing``,
    ``attitude_err_arcsec`` (star tracker), ``time_s`` and ``filter`` (the estimate ``x`` and
    covariance ``P``, which the spacecraft knows).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 15}  # noqa: RUF012 (Gymnasium convention)

    def __init__(
        self, config: EnvConfig | dict | None = None, render_mode: str | None = None, **overrides: Any
    ):
        if isinstance(config, EnvConfig):
            cfg = EnvConfig.from_dict(config.to_dict(), **overrides) if overrides else config
        else:
            cfg = EnvConfig.from_dict(config or {}, **overrides)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InvalidParameterError(
                f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.config = cfg
        self.render_mode = render_mode
        self.planets = cfg.planets
        n = cfg.n_planets
        self._radii = np.array([body(p).radius for p in self.planets])
        self._diameters = 2.0 * self._radii
        self._ephemeris = DEEphemeris()
        self._approach = cfg.scenario == "mars-approach"
        if self._approach:
            ep = approach_episode(cfg.episode_steps * cfg.step_s, cfg.approach_end_before_ca_h)
            self._gravity = GravityModel(ep.central, ep.perturbers)
        else:
            self._gravity = GravityModel("sun")
        # Observation scales: heliocentric AU and 30 km/s in cruise; 10^6 km and 5 km/s on approach.
        self._pos_scale, self._vel_scale = (1.0e6, 5.0) if self._approach else (AU_KM, 30.0)
        self._mus = np.asarray(self._gravity.mu_perturbers, dtype=float)
        self.pulsars = cfg.pulsars
        self._psr = [psr.pulsar(name) for name in cfg.pulsars]
        self._psr_dirs = np.array([p.direction for p in self._psr]).reshape(-1, 3)
        self._psr_lambda = np.array([p.wavelength_km for p in self._psr])
        self._psr_sigma = np.array([psr.phase_sigma_cycles(p, cfg.detector) for p in self._psr])
        sigma_dir = np.hypot(cfg.camera.sigma_direction_rad, cfg.star_tracker_sigma_arcsec * ARCSEC)
        self._meas = MeasurementModel(
            cfg.measurement_model, sigma_dir=sigma_dir, sigma_size=cfg.camera.sigma_alpha_rad
        )
        self._kind = KIND_CODES[cfg.measurement_model]
        # The thesis's star camera is one instrument: the stars in the planet image give the attitude.
        # Sharing the boresight matters: a tracker's weak axis is roll about its own boresight, which
        # would swing a camera mounted elsewhere by ~14" (measured) instead of ~1.4".
        self._tracker = StarTrackerConfig(
            boresight_body=tuple(float(v) for v in cfg.camera.boresight_body),
            fov_deg=float(np.degrees(2.0 * min(cfg.camera.half_fov_rad))),
        )
        att = cfg.attitude
        self._jm = np.diag(np.asarray(att.inertia, dtype=float))
        self._jinv = np.linalg.inv(self._jm)
        self._tau_max = np.full(3, att.wheel_torque_limit)
        self._h_max = np.full(3, att.wheel_momentum_capacity)
        self._boresight_body = cfg.camera.boresight_body
        # Disk wider than the field <=> asin(R/L) > half field <=> R > L sin(half field).
        self._sin_half_fov = math.sin(min(cfg.camera.half_fov_rad))

        n_targets = cfg.n_targets
        if cfg.action_mode == "target":
            self.action_space = spaces.Discrete(n_targets + (1 if cfg.idle_action else 0))
        elif cfg.action_mode == "torque":
            self.action_space = spaces.Box(-1.0, 1.0, (3,), dtype=np.float32)
        else:
            self.action_space = spaces.Box(-1.0, 1.0, (n + 3,), dtype=np.float32)
        n_psr = cfg.n_pulsars
        self._obs_dim = 22 + PLANET_FEATURES * (n + n_psr) + n_targets + 1
        if cfg.observation == "box":
            self.observation_space = spaces.Box(-np.inf, np.inf, (self._obs_dim,), dtype=np.float32)
        else:
            f32 = np.float32
            self.observation_space = spaces.Dict(
                {
                    "position": spaces.Box(-np.inf, np.inf, (3,), f32),
                    "velocity": spaces.Box(-np.inf, np.inf, (3,), f32),
                    "log_sigma": spaces.Box(-np.inf, np.inf, (6,), f32),
                    "attitude": spaces.Box(-1.0, 1.0, (4,), f32),
                    "rates": spaces.Box(-np.inf, np.inf, (3,), f32),
                    "wheel_momentum": spaces.Box(-1.0, 1.0, (3,), f32),
                    "planets": spaces.Box(-np.inf, np.inf, (n, PLANET_FEATURES), f32),
                    "target": spaces.Box(0.0, 1.0, (n_targets,), f32),
                    "elapsed": spaces.Box(0.0, 1.0, (1,), f32),
                }
            )
            if n_psr:
                self.observation_space.spaces["pulsars"] = spaces.Box(
                    -np.inf, np.inf, (n_psr, PLANET_FEATURES), f32
                )
        self._ekf: SingleEKF | None = None
        self._done = False
        self._z = np.empty(3)
        self._basis = np.empty((2, 3))
        self._features = np.empty((n, PLANET_FEATURES))
        self._obs_buf = np.empty(self._obs_dim)
        self._codes = np.empty(n, dtype=np.int8)
        self._r_tile = np.empty((n, 3))
        self._q_tile = np.empty((n, 4))
        self._los = np.empty((1, 3))
        self._alpha = np.empty(1)
        self._pix = np.empty((1, 2))

    # ------------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        cfg = self.config
        rng = self.np_random
        if self._approach:
            ep = approach_episode(cfg.episode_steps * cfg.step_s, cfg.approach_end_before_ca_h)
        else:
            ep = draw_episode(cfg.scenario, rng, self._ephemeris, self.planets, cfg.camera.sun_exclusion_deg)
        self._epoch = ep.epoch
        self._k = 0
        self._done = False
        k_total = cfg.episode_steps
        # Ephemerides at every half step of the episode (the RK4 stages ask for exactly these times):
        # one vectorised call per body. Targets are heliocentric (the camera's frame, Sun at the
        # origin); the truth and the filter work relative to the central body.
        half = ep.epoch + 0.5 * cfg.step_s * np.arange(2 * k_total + 3)
        eph = self._ephemeris
        self._central_helio = np.ascontiguousarray(
            eph.position(ep.central, half) if ep.central != "sun" else np.zeros((len(half), 3))
        )
        # (2K+3, P, 3): one contiguous (P, 3) slice per half step.
        self._table = np.ascontiguousarray(np.stack([eph.position(p, half) for p in self.planets], axis=1))
        self._pert = np.ascontiguousarray(
            np.stack([eph.position(b, half) - self._central_helio for b in ep.perturbers], axis=1)
            if ep.perturbers
            else np.zeros((len(half), 0, 3))
        )
        if self.pulsars:
            self._central_ssb = self._central_helio + psr.sun_ssb_position(half)
        self._integrated = 0.0
        self._phase_skipped = 0
        self._sensor = None
        self._x = ep.x0.copy()
        p0 = cfg.filter.initial_covariance()
        x_est = self._x + rng.multivariate_normal(np.zeros(6), p0)
        self._ekf = SingleEKF(self._gravity, x_est, p0, cfg.filter)
        self._q = qt.normalize(rng.normal(size=4))
        self._w = np.zeros(3)
        self._h = np.zeros(3)
        self._u_last = np.zeros(3)
        self._target = -1
        self._q_est, self._att_err = self._star_fix()
        self._w_meas = self._w + rng.normal(0.0, cfg.attitude.rate_noise_deg_s * _DEG, 3)
        self._history: list[tuple[float, float]] = []
        self._last_measurement: dict[str, Any] = {}
        info = self._info(measured=False, rejected=False, reason="none", slewing=False)
        self._history.append((info["pos_err_km"], info["pos_sigma_km"]))
        return self._observation(), info

    # ------------------------------------------------------------------------------------------
    def _decode(self, action: Any) -> tuple[int, np.ndarray | None]:
        """(target index or -1 for none/idle, torque fraction (3,) or None)."""
        cfg = self.config
        if cfg.action_mode == "target":
            if type(action) is int or isinstance(action, np.integer):  # the common case, checked cheaply
                idx = int(action)
                if not 0 <= idx < self.action_space.n:
                    raise InvalidParameterError(
                        f"target action must be an integer in [0, {self.action_space.n}), got {action!r}"
                    )
                return (-1, None) if idx == cfg.n_targets else (idx, None)
            a = np.asarray(action)
            if a.size != 1 or not np.issubdtype(a.dtype, np.number):
                raise InvalidParameterError(f"target action must be one integer, got {action!r}")
            if not np.all(np.isfinite(a)):
                raise NonFiniteError(f"action is not finite: {action!r}")
            idx = int(a.reshape(()))
            if idx != a.reshape(()) or not 0 <= idx < self.action_space.n:
                raise InvalidParameterError(
                    f"target action must be an integer in [0, {self.action_space.n}), got {action!r}"
                )
            if idx == cfg.n_targets:  # the idle action
                return -1, None
            return idx, None
        a = np.asarray(action, dtype=float).reshape(-1)
        if a.shape != self.action_space.shape:
            raise InvalidParameterError(
                f"action must have shape {self.action_space.shape}, got {np.shape(action)}"
            )
        if not np.all(np.isfinite(a)):
            raise NonFiniteError(f"action contains NaN or infinite values: {a.tolist()}")
        a = np.clip(a, -1.0, 1.0)
        if cfg.action_mode == "torque":
            return -1, a
        return int(np.argmax(a[: cfg.n_planets])), a[cfg.n_planets :]

    def _planet_pos(self, half_index: int) -> np.ndarray:
        """Heliocentric planet positions (P, 3) at half step ``half_index``."""
        return self._table[half_index]

    def _target_direction(self, target: int, k: int, r_est_helio: np.ndarray) -> np.ndarray:
        """Inertial direction (not normalised) from the estimated position to target ``target``."""
        if target < self.config.n_planets:
            return self._table[2 * k, target] - r_est_helio
        return self._psr_dirs[target - self.config.n_planets]

    def step(self, action: Any):
        if self._ekf is None:
            raise RuntimeError("call reset() before step()")
        if self._done:
            raise RuntimeError("the episode has ended (terminated or truncated): call reset() before step()")
        cfg = self.config
        target, torque_frac = self._decode(action)
        k = self._k
        ekf = self._ekf
        t = self._epoch + k * cfg.step_s

        # --- attitude: PD law toward the estimated direction of the target, and/or agent torque ---
        r_est_helio = ekf.x[:3] + self._central_helio[2 * k]
        use_pd = target >= 0 and cfg.action_mode != "torque"
        direction = self._target_direction(target, k, r_est_helio) if use_pd else self._boresight_body
        bias = torque_frac * self._tau_max if torque_frac is not None else _ZERO3
        slewing = use_pd and target != self._target and self._target >= 0
        if target != self._target:
            self._integrated = 0.0  # an X-ray integration is lost when the detector leaves its pulsar
        if use_pd:
            self._target = target
        elif cfg.action_mode == "target":
            self._target = -1
        ok = _attitude_substeps(
            self._q, self._w, self._h, use_pd, direction, r_est_helio, bias, cfg.n_substeps,
            cfg.attitude_substep_s, self._jm, self._jinv, self._tau_max, self._h_max,
            cfg.attitude.k_a, cfg.attitude.k_w, self._u_last,
        )  # fmt: skip
        if not ok:
            raise NonFiniteError(
                f"attitude state became non-finite at step {k} (q={self._q}, omega={self._w})"
            )

        # --- orbit truth and filter prediction (same dynamics, perturbers from the table) ---
        pert = (self._pert[2 * k], self._pert[2 * k + 1], self._pert[2 * k + 2])
        rk4_batch_kernel(self._x.reshape(1, 6), cfg.step_s, self._gravity.mu_central, *pert, self._mus)
        ekf.predict(t, cfg.step_s, pert)
        self._k = k = k + 1
        rng = self.np_random

        # --- sensors ---
        self._q_est, self._att_err = self._star_fix()
        self._w_meas = self._w + rng.normal(0.0, cfg.attitude.rate_noise_deg_s * _DEG, 3)
        measured = rejected = False
        reason = "none"
        sensor = None
        if target >= cfg.n_planets:
            measured, rejected, reason = self._time_pulsar(target - cfg.n_planets)
            sensor = "xray" if measured else None
        else:
            planets_now = self._planet_pos(2 * k)
            r_helio = self._x[:3] + self._central_helio[2 * k]
            meas_index = (
                target if cfg.action_mode != "torque" else self._nearest_in_view(planets_now, r_helio)
            )
            if cfg.action_mode == "torque":
                self._target = meas_index
            if meas_index >= 0:
                code = int(
                    self._visible_reasons(
                        r_helio[None], self._q[None], planets_now[meas_index : meas_index + 1],
                        self._radii[meas_index : meas_index + 1], planets_now,
                    )[0]
                )  # fmt: skip
                reason = _REASONS[code]
                if code == 0 and self._too_large(meas_index, planets_now[meas_index], r_helio):
                    code, reason = -1, "too_large"
                if code == 0:
                    measured, rejected = self._measure(meas_index, planets_now[meas_index], r_helio)
                    sensor = "camera"
        self._sensor = sensor

        info = self._info(measured, rejected, reason, slewing)
        pos_err = info["pos_err_km"]
        # A non-finite covariance shows in its trace; a non-finite estimate in pos_err.
        terminated = (
            not (math.isfinite(pos_err) and math.isfinite(info["pos_sigma_km"]))
            or pos_err > cfg.divergence_km
        )
        truncated = k >= cfg.episode_steps and not terminated
        self._done = bool(terminated or truncated)
        reward = self._reward(info, torque_frac)
        self._history.append((info["pos_err_km"], info["pos_sigma_km"]))
        return self._observation(), reward, bool(terminated), bool(truncated), info

    # ------------------------------------------------------------------------------------------
    def _star_fix(self) -> tuple[np.ndarray, float]:
        if self.config.star_tracker == "ideal":
            return self._q.copy(), 0.0
        try:
            q_est, err = estimate_attitude(self.np_random, self._q, self._tracker)
        except NotVisibleError:
            # Too few stars in the field: keep the last fix (stale), reported as a large error.
            return self._q_est, float("nan")
        return q_est, float(err)

    def _nearest_in_view(self, planets_now: np.ndarray, r_helio: np.ndarray) -> int:
        """Index of the planet nearest the boresight by the true geometry (what the image shows), or -1."""
        boresight = qt.rotate_body_to_inertial(self._q, self._boresight_body)
        d = planets_now - r_helio
        cosang = d @ boresight / np.linalg.norm(d, axis=1)
        i = int(np.argmax(cosang))
        return i if cosang[i] > np.cos(self.config.camera.half_fov_diagonal_rad) else -1

    def _too_large(self, i: int, planet_helio: np.ndarray, r_helio: np.ndarray) -> bool:
        """A disk wider than the sensor's field cannot give its centre or diameter (close approach)."""
        d0, d1, d2 = planet_helio[0] - r_helio[0], planet_helio[1] - r_helio[1], planet_helio[2] - r_helio[2]
        return self._radii[i] > self._sin_half_fov * math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)

    def _measure(self, i: int, planet: np.ndarray, r_helio: np.ndarray) -> tuple[bool, bool]:
        """Camera measurement of planet i, rotated to inertial with the star-tracker attitude; EKF update."""
        cfg = self.config
        # camera.measure's kernel, with the same single standard-normal draw (1, 3); the public
        # wrapper's validation costs more than the measurement (visibility was checked just before).
        noise = self.np_random.standard_normal((1, 3))
        st = cam.measure_into_kernel(
            r_helio[None], self._q[None], planet[None], self._radii[i : i + 1], noise,
            cfg.camera._c2b, cfg.camera._params, self._los, self._alpha, self._pix,
        )  # fmt: skip
        if st != 0:  # let the public function raise its specific error
            cam.measure(self.np_random, r_helio, self._q, planet, self._radii[i], cfg.camera)
        ekf = self._ekf
        planet_rel = planet - self._central_helio[2 * self._k]  # the filter's frame
        dim = _measurement_vector(
            self._los[0], self._alpha[0], self._q_est, planet_rel, ekf.x, self._kind, self._z, self._basis
        )
        nis, ok = ekf.update_planet(
            self._z[:dim],
            planet_rel,
            self._diameters[i],
            self._meas,
            self._basis if self._kind >= 2 else None,
        )
        self._last_measurement = {
            "planet": self.planets[i],
            "nis": nis,
            "accepted": ok,
            "pixel": self._pix[0].copy(),
        }
        return True, not ok

    def _time_pulsar(self, j: int) -> tuple[bool, bool, str]:
        """Accumulate X-ray photons from pulsar j while the detector points at it; after the detector's
        integration time, a phase measurement (range along the pulsar's line of sight, relative to the
        Solar-system barycentre) updates the filter. Returns (measured, rejected, reason)."""
        cfg = self.config
        k = self._k
        n = self._psr_dirs[j]
        r_helio = self._x[:3] + self._central_helio[2 * k]
        boresight = qt.rotate_body_to_inertial(self._q, self._boresight_body)
        off = math.acos(min(max(float(boresight @ n), -1.0), 1.0))
        occulter = self._central_helio[2 * k] if self._approach else None
        vis = psr.pulsar_visibility(
            r_helio, [self._psr[j]], cfg.detector, occulter,
            body(self._gravity.central).radius if occulter is not None else None,
        )  # fmt: skip
        if vis.sun_blocked[0, 0]:
            self._integrated = 0.0
            return False, False, "sun_exclusion"
        if vis.occulted[0, 0]:
            self._integrated = 0.0
            return False, False, "occulted"
        if off > math.radians(0.5 * cfg.detector_fov_deg):
            self._integrated = 0.0
            return False, False, "out_of_fov"
        self._integrated += cfg.step_s
        if self._integrated + 1e-9 < cfg.detector.integration_time_s:
            return False, False, "integrating"
        self._integrated = 0.0
        lam = self._psr_lambda[j]
        sigma = self._psr_sigma[j]
        r_ssb = self._x[:3] + self._central_ssb[2 * k]
        total = float(n @ r_ssb) / lam + sigma * float(self.np_random.standard_normal())
        frac = total - math.floor(total)  # what the detector delivers: the phase within a cycle
        ekf = self._ekf
        h = float(n @ (ekf.x[:3] + self._central_ssb[2 * k])) / lam
        jac = np.zeros(6)
        jac[:3] = n / lam
        sig_pred = math.sqrt(float(jac @ ekf.P @ jac) + sigma * sigma)
        if cfg.ambiguity_k_sigma * sig_pred >= 0.5:
            self._phase_skipped += 1  # the whole number of cycles cannot be trusted: skip, count
            return False, False, "ambiguous"
        z = frac + round(h - frac)  # cycle ambiguity resolved against the prediction
        nis, ok = ekf.update_scalar(z, h, jac, sigma * sigma)
        self._last_measurement = {"pulsar": self.pulsars[j], "nis": nis, "accepted": ok}
        return True, not ok, "visible"

    def _target_name(self, index: int) -> str | None:
        if index < 0:
            return None
        n = self.config.n_planets
        return self.planets[index] if index < n else self.pulsars[index - n]

    def _reward(self, info: dict, torque_frac: np.ndarray | None) -> float:
        cfg = self.config
        err = info["pos_err_km"] if cfg.reward == "truth" else info["pos_sigma_km"]
        r = -float(err) / cfg.reward_scale_km
        if torque_frac is not None and cfg.torque_penalty > 0:
            r -= cfg.torque_penalty * float(torque_frac @ torque_frac)
        return r if np.isfinite(r) else -cfg.divergence_km / cfg.reward_scale_km

    def _info(self, measured: bool, rejected: bool, reason: str, slewing: bool) -> dict[str, Any]:
        ekf = self._ekf
        e = ekf.x - self._x
        p = ekf.P
        return {
            "pos_err_km": math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2]),
            "vel_err_km_s": math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5]),
            "nees": float(_nees(ekf.x, self._x, p)),
            "pos_sigma_km": math.sqrt(max(p[0, 0] + p[1, 1] + p[2, 2], 0.0)),
            "measured": measured,
            "rejected": rejected,
            "target": self._target_name(self._target),
            "sensor": getattr(self, "_sensor", None),
            "ambiguous_skipped": self._phase_skipped,
            "visibility": reason,
            "slewing": slewing,
            "attitude_err_arcsec": self._att_err / ARCSEC,
            "time_s": self._epoch + self._k * self.config.step_s,
            "filter": {"x": ekf.x.copy(), "P": ekf.P.copy()},
        }

    # ------------------------------------------------------------------------------------------
    def planet_features(self) -> np.ndarray:
        """(P, 7) per-planet observation block from the estimate (see the class docstring)."""
        cfg = self.config
        ekf = self._ekf
        planets_now = self._planet_pos(2 * self._k)
        out = self._features
        r_est_helio = ekf.x[:3] + self._central_helio[2 * self._k]
        _planet_geometry(
            r_est_helio, self._q_est, ekf.P[:3, :3], planets_now, self._radii, self._boresight_body, out,
            self._q_tile,
        )  # fmt: skip
        # Observable if pointed at: the camera's own rules (Sun exclusion, occultation, size) for the
        # attitude that would centre the planet; the disk must also fit in the field.
        self._r_tile[:] = r_est_helio
        reason = self._visible_reasons(self._r_tile, self._q_tile, planets_now, self._radii, planets_now)
        out[:, 5] = (reason == 0) & (out[:, 4] < 2.0 * min(cfg.camera.half_fov_rad))
        out[:, 4] /= cfg.camera.sigma_alpha_rad
        return out.copy()

    def pulsar_features(self) -> np.ndarray:
        """(Q, 7) per-pulsar observation block: direction in body axes from the star-tracker attitude
        (3), integration progress (0..1, current target only), log10 of the filter's predicted 1-sigma
        of the phase [cycles], observable (not Sun-blocked or occulted, from the estimate), log10 of the
        position 1-sigma along the pulsar's direction [km] / 4."""
        cfg = self.config
        ekf = self._ekf
        k = self._k
        out = np.empty((cfg.n_pulsars, PLANET_FEATURES))
        out[:, 0:3] = qt.rotate_inertial_to_body(self._q_est, self._psr_dirs)
        out[:, 3] = 0.0
        if self._target >= cfg.n_planets:
            out[self._target - cfg.n_planets, 3] = self._integrated / cfg.detector.integration_time_s
        var_along = np.einsum("qi,ij,qj->q", self._psr_dirs, ekf.P[:3, :3], self._psr_dirs)
        out[:, 4] = np.log10(np.sqrt(var_along / self._psr_lambda**2 + self._psr_sigma**2))
        r_est_helio = ekf.x[:3] + self._central_helio[2 * k]
        occulter = self._central_helio[2 * k] if self._approach else None
        vis = psr.pulsar_visibility(
            r_est_helio, self._psr, cfg.detector, occulter,
            body(self._gravity.central).radius if occulter is not None else None,
        )  # fmt: skip
        out[:, 5] = vis.visible[0]
        out[:, 6] = np.log10(np.sqrt(np.maximum(var_along, 1e-12))) / 4.0
        return out

    def _visible_reasons(self, r, q, targets, radii, occulters) -> np.ndarray:
        """Camera visibility reason codes (0 = visible) from the camera's codes-only kernel: the public
        ``camera.visibility`` validates and wraps its inputs, which costs more than the geometry here."""
        cfg = self.config.camera
        out = self._codes[: len(targets)]
        st = cam.visibility_codes_kernel(
            r, q, targets, radii, occulters.reshape(1, -1, 3), self._radii, True, cfg._c2b, cfg._params, out
        )
        if st != 0:  # a bad geometry: let the public function raise its specific error
            cam.visibility(r, q, targets, occulters, self._radii, radii, cfg)
        return out

    def _observation(self):
        cfg = self.config
        ekf = self._ekf
        n = cfg.n_planets
        buf = self._obs_buf
        _spacecraft_block(
            buf,
            ekf.x,
            ekf.P,
            self._q_est,
            self._w_meas,
            self._h,
            self._h_max,
            self._pos_scale,
            self._vel_scale,
        )
        end = 22 + PLANET_FEATURES * n
        buf[22:end] = self.planet_features().ravel()
        if cfg.n_pulsars:
            end_p = end + PLANET_FEATURES * cfg.n_pulsars
            buf[end:end_p] = self.pulsar_features().ravel()
        else:
            end_p = end
        n_t = cfg.n_targets
        buf[end_p : end_p + n_t] = 0.0
        if self._target >= 0:
            buf[end_p + self._target] = 1.0
        buf[-1] = self._k / cfg.episode_steps
        if cfg.observation == "box":
            return buf.astype(np.float32)
        f = buf.astype(np.float32)
        out = {
            "position": f[0:3], "velocity": f[3:6], "log_sigma": f[6:12], "attitude": f[12:16],
            "rates": f[16:19], "wheel_momentum": f[19:22], "planets": f[22:end].reshape(n, PLANET_FEATURES),
            "target": f[end_p : end_p + n_t], "elapsed": f[-1:],
        }  # fmt: skip
        if cfg.n_pulsars:
            out["pulsars"] = f[end:end_p].reshape(cfg.n_pulsars, PLANET_FEATURES)
        return out

    def decode_observation(self, observation: Any) -> dict[str, Any]:
        """Named arrays in physical units from a ``box`` or ``dict`` observation of this env:
        position_km, velocity_km_s (relative to the central body), log_sigma (6,), q (star tracker),
        rates_rad_s, wheel_fraction, planets (P, 7) and pulsars (Q, 7) as laid out in the class
        docstring, target (index or -1), elapsed."""
        cfg = self.config
        n, nq = cfg.n_planets, cfg.n_pulsars
        if isinstance(observation, dict):
            o = {k: np.asarray(v, dtype=float) for k, v in observation.items()}
            flat = np.concatenate(
                [
                    o[k].ravel()
                    for k in ("position", "velocity", "log_sigma", "attitude", "rates", "wheel_momentum")
                ]
                + [o["planets"].ravel(), o.get("pulsars", np.zeros(0)).ravel(), o["target"], o["elapsed"]]
            )
        else:
            flat = np.asarray(observation, dtype=float).reshape(-1)
        if flat.size != self._obs_dim:
            raise InvalidParameterError(
                f"observation has {flat.size} values; this environment's have {self._obs_dim}"
            )
        end = 22 + PLANET_FEATURES * n
        end_p = end + PLANET_FEATURES * nq
        target_vec = flat[end_p : end_p + cfg.n_targets]
        return {
            "position_km": flat[0:3] * self._pos_scale,
            "velocity_km_s": flat[3:6] * self._vel_scale,
            "log_sigma": flat[6:12],
            "q": flat[12:16] / np.linalg.norm(flat[12:16]),
            "rates_rad_s": flat[16:19] * _DEG,
            "wheel_fraction": flat[19:22],
            "planets": flat[22:end].reshape(n, PLANET_FEATURES),
            "pulsars": flat[end:end_p].reshape(nq, PLANET_FEATURES),
            "target": int(np.argmax(target_vec)) if np.any(target_vec > 0.5) else -1,
            "elapsed": float(flat[-1]),
        }

    # ------------------------------------------------------------------------------------------
    def render(self):
        if self.render_mode != "rgb_array":
            return None
        from planetnav_env.render import render_frame

        return render_frame(self)

    @property
    def truth(self) -> dict[str, np.ndarray]:
        """The true state (for analysis and tests; agents must not read it)."""
        return {"x": self._x.copy(), "q": self._q.copy(), "omega": self._w.copy(), "h_w": self._h.copy()}
