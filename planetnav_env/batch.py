"""BatchCore: the state of N environment rows as arrays, and the Python side of reset and step.

Both environments are shells over this class: :class:`~planetnav_env.envs.env.PlanetNavEnv` holds a batch of
one, :class:`~planetnav_env.envs.vector_env.PlanetNavVectorEnv` a batch of ``num_envs``. The compiled step is
:mod:`planetnav_env.core.kernels`; here live what needs Python: drawing an episode (the scenario, the
initial error, from the row's ``numpy`` generator), fitting the row's ephemeris table, choosing the
serial or the threaded loop, and turning row statuses into named errors. It sits above the core: it reads
the :class:`~planetnav_env.config.EnvConfig` and builds the kernels' parameters with
:mod:`planetnav_env.kernel_params`, so that ``planetnav_env.core`` imports no configuration.

Memory per row (default cruise, 3 planets, 1 day): state 166 floats (47 of them the counters of the
observation's history blocks) + 13 ints, covariance 36 floats, observation 47 floats, random state 32
bytes, ephemeris table 936 bytes: about 3.1 kB
(:meth:`BatchCore.bytes_per_row` computes it for any configuration).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from planetnav_env.astro.ephemeris import DEEphemeris, ephemeris_path
from planetnav_env.attitude import quaternion as qt
from planetnav_env.config import EnvConfig
from planetnav_env.core import kernels as K
from planetnav_env.core import layout as L
from planetnav_env.core import rng as crng
from planetnav_env.core.ephemeris_table import SEGMENT_S, TableSpec, fit_table
from planetnav_env.core.params import ARCSEC, ChannelPlan
from planetnav_env.core.records import RowState
from planetnav_env.dynamics.orbit import GravityModel
from planetnav_env.dynamics.srp import srp_gm
from planetnav_env.errors import NonFiniteError, PlanetNavError
from planetnav_env.kernel_params import build_params, episode_duration_s
from planetnav_env.scenarios.episodes import Episode, approach_episode, draw_episode
from planetnav_env.sensors.pulsar import SPEED_OF_LIGHT_KM_S
from planetnav_env.sensors.star_tracker import read_only
from planetnav_env.world import truth_perturbers, tuned_accel_psd

#: Batches at least this large step in chunks on several threads (smaller ones are faster serially:
#: handing chunks to threads costs ~20-50 us a step).
PARALLEL_MIN_ROWS = 64


def attitude_err_arcsec(att_rad: Any) -> Any:
    """The star tracker's attitude error [rad] in arcsec; a non-finite value (no star fix) reads NaN,
    never +-inf. Scalars and arrays alike (the single env's info and the vector env's)."""
    if type(att_rad) is float:  # the single env's info (a Python float): no numpy call (~3 us a step)
        return att_rad / ARCSEC if math.isfinite(att_rad) else math.nan
    # Dividing inf or NaN by a constant raises no floating-point warning, so no np.errstate is needed;
    # the finiteness test is on the value in radians.
    att_rad = np.asarray(att_rad)
    return np.where(np.isfinite(att_rad), att_rad / ARCSEC, np.nan)


def _kernel_array(a: np.ndarray, dtype: type) -> np.ndarray:
    """``a`` as the compiled step takes it: C-contiguous and writable, of ``dtype`` (``a`` itself when it
    already is; a copy of a read-only or strided array)."""
    out = np.ascontiguousarray(a, dtype=dtype)
    return out if out.flags.writeable else out.copy()


def _time_s(t0: Any, k: Any, step_s: float) -> Any:
    """Ephemeris time [s] of step ``k`` of an episode starting at ``t0`` [s] (scalars or arrays): the
    one formula of the single env's ``info["time_s"]`` and the vector env's."""
    return t0 + k * step_s


#: State columns the batch info gathers (:meth:`BatchCore.info_batch_columns`): row ``FC_X`` of ``fc``
#: is column ``F_X`` of ``f``, row ``IC_X`` of ``ic`` column ``I_X`` of ``i``.
FC_POS_ERR, FC_VEL_ERR, FC_NEES, FC_POS_SIGMA, FC_T0, FC_ATT_ERR = range(6)
INFO_F = np.array([L.F_POS_ERR, L.F_VEL_ERR, L.F_NEES, L.F_POS_SIGMA, L.F_T0, L.F_ATT_ERR])
IC_TARGET, IC_REASON, IC_K, IC_SKIPPED, IC_SENSOR, IC_MEASURED, IC_REJECTED, IC_SLEWING = range(8)
INFO_I = np.array(
    [L.I_TARGET, L.I_REASON, L.I_K, L.I_SKIPPED, L.I_SENSOR, L.I_MEASURED, L.I_REJECTED, L.I_SLEWING]
)
#: The rows of ``ic`` that are flags, in this order: measured, rejected, slewing.
_INFO_FLAGS = slice(IC_MEASURED, IC_SLEWING + 1)


def default_threads() -> int:
    """Threads for large batches: ``PLANETNAV_THREADS`` or the CPUs this process may use."""
    env = os.environ.get("PLANETNAV_THREADS")
    if env:
        return max(1, int(env))
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


@dataclass(frozen=True)
class RowEpisode:
    """What :meth:`BatchCore.reset_rows` drew for a row (kept for analysis and rendering)."""

    epoch: float
    central: str
    perturbers: tuple[str, ...]


class BatchCore:
    """State of ``num_rows`` environments (leading axis) and the calls that advance them.

    Arrays (public, read-only for callers): ``f`` (N, NF) float state, ``p`` (N, 6, 6) filter covariance,
    ``i`` (N, NI) integer state, ``rng`` (N, 4) random streams, ``eph`` per-row ephemeris tables,
    ``obs`` (N, obs_dim) observations; columns are named in :mod:`planetnav_env.core.layout`.
    """

    def __init__(self, config: EnvConfig, num_rows: int) -> None:
        if int(num_rows) != num_rows or num_rows < 1:
            raise PlanetNavError(f"num_rows must be a positive integer, got {num_rows!r}")
        self.config = cfg = config
        self.num_rows = n = int(num_rows)
        self.approach = cfg.scenario == "mars-approach"
        if self.approach:
            ep = approach_episode(cfg.episode_steps * cfg.step_s, cfg.approach_end_before_ca_h)
            central, perturbers = ep.central, ep.perturbers
        else:
            central, perturbers = "sun", ()
        self.gravity = GravityModel(central, perturbers)
        # The truth's own force model (world.truth_forces_on): every planet as a third body, or with SRP
        # or its own ephemeris alone the filter's perturbers, in channels of its own; with SRP on a
        # planetary approach the Sun is among them (its direction and distance).
        world = cfg.world
        if world.truth_forces_on:
            bodies = truth_perturbers(central) if world.third_bodies_on else tuple(perturbers)
            if world.srp_on and central != "sun" and "sun" not in bodies:
                bodies = ("sun", *bodies)
            self.truth_gravity: GravityModel | None = GravityModel(central, bodies)
        else:
            self.truth_gravity = None
        truth_bodies = self.truth_gravity.perturbers if self.truth_gravity is not None else ()
        self.plan = ChannelPlan(
            central,
            cfg.planets,
            tuple(perturbers),
            bool(cfg.pulsars),
            truth_bodies,
            world.truth_ephemeris_apart,
        )
        truth_mus = None
        if self.truth_gravity is not None:
            truth_mus = np.asarray(self.truth_gravity.mu_perturbers, dtype=float)
        self.params = build_params(
            cfg, self.plan, self.gravity.mu_central, np.asarray(self.gravity.mu_perturbers, dtype=float),
            truth_mus,
        )  # fmt: skip
        self.layout = L.ObservationLayout.for_config(cfg)
        self.table_spec = TableSpec.for_duration(
            episode_duration_s(cfg), max(self.plan.n_channels, 1), segment_s=SEGMENT_S
        )
        self.f = np.zeros((n, L.NF))
        self.p = np.zeros((n, 6, 6))
        self.i = np.zeros((n, L.NI), dtype=np.int64)
        self.rng = np.zeros((n, crng.STATE_WORDS), dtype=np.uint64)
        self.eph = np.zeros((n, *self.table_spec.shape))
        self.obs = np.zeros((n, self.layout.size))
        self.episodes: list[RowEpisode | None] = [None] * n
        self._ephemeris = DEEphemeris()
        # The truth's ephemeris (world.truth_ephemeris): DE421 itself, or DE440 mapped once per process.
        self._truth_ephemeris = (
            DEEphemeris(ephemeris_path(world.truth_ephemeris_name))
            if world.truth_ephemeris_apart
            else self._ephemeris
        )
        self._table_cache: tuple[float, np.ndarray] | None = None
        self._all = np.ones(n, dtype=np.bool_)
        # The decoding of the rows' actions (kernels.decide_row writes it at a decision's start).
        self._targets = np.full(n, -1, dtype=np.int64)
        self._torques = np.zeros((n, 3))
        self._p0 = cfg.filter.initial_covariance()
        # P0 is diagonal: the initial error is a standard normal draw per axis times its sigma (the numbers
        # Generator.multivariate_normal gives for a diagonal P0, without its BLAS-dependent SVD and product).
        self._sigma0 = np.sqrt(np.diagonal(self._p0))
        self.threads = default_threads() if n >= PARALLEL_MIN_ROWS else 1
        self._pool: ThreadPoolExecutor | None = None

    @property
    def state(self) -> RowState:
        """The state arrays as the kernels' record (the arrays themselves, not copies)."""
        return RowState(f=self.f, p=self.p, i=self.i, rng=self.rng, eph=self.eph, obs=self.obs)

    # ------------------------------------------------------------------------------------------
    def bytes_per_row(self) -> int:
        """Bytes of state one row holds (all arrays of the batch divided by the rows)."""
        total = sum(a.nbytes for a in (self.f, self.p, self.i, self.rng, self.eph, self.obs))
        return total // self.num_rows

    def _draw(self, gen: np.random.Generator) -> Episode:
        cfg = self.config
        if self.approach:
            return approach_episode(cfg.episode_steps * cfg.step_s, cfg.approach_end_before_ca_h)
        return draw_episode(cfg.scenario, gen, self._ephemeris, cfg.planets, cfg.camera.sun_exclusion_deg)

    def _table(self, epoch: float) -> np.ndarray:
        # Fixed scenarios start every row at the same epoch: fit once, copy.
        if self._table_cache is not None and self._table_cache[0] == epoch:
            return self._table_cache[1]
        spec = self.table_spec
        if self.plan.n_channels == 0:
            coeffs = np.zeros(spec.shape)
        else:
            coeffs = fit_table(
                lambda t: self.plan.positions(self._ephemeris, t, self._truth_ephemeris), epoch, spec.span_s,
                spec.n_channels,
                segment_s=spec.segment_s, degree=spec.degree,
            )  # fmt: skip
        self._table_cache = (epoch, coeffs)
        return coeffs

    def reset_rows(self, rows: np.ndarray, generators: list[np.random.Generator]) -> None:
        """Start a new episode in each of ``rows``, drawing it from the matching ``generators`` entry
        (the row's Gymnasium ``np_random``): scenario, initial filter error, attitude, then the row's
        compiled random stream. The same generator state gives the same row, whatever the batch."""
        rows = np.asarray(rows, dtype=np.int64).reshape(-1)
        for r, gen in zip(rows, generators, strict=True):
            self.episodes[r] = self.draw_row(gen, self.f[r], self.p[r], self.rng[r], self.eph[r])
        K.reset_rows(self.params, self.state, rows)

    def draw_row(
        self, gen: np.random.Generator, f: np.ndarray, p: np.ndarray, rng: np.ndarray, eph: np.ndarray
    ) -> RowEpisode:
        """What a reset draws on the host for one row, from ``gen``, written into that row's arrays: ``f``
        (NF,) the float state (zeroed, then the epoch [s], true state [km, km/s], filter estimate,
        attitude and the episode's events), ``p`` (6, 6) the initial covariance [km^2, km^2/s^2], ``rng``
        (STATE_WORDS,) uint64 the compiled noise stream, ``eph`` the ephemeris table. :meth:`reset_rows`
        passes views of the batch's rows; the device env's episode bank
        (:mod:`planetnav_env.device.bank`) views of its own. The compiled part of the reset
        (``kernels.reset_row``) then runs on the row."""
        cfg = self.config
        ep = self._draw(gen)
        eph[...] = self._table(ep.epoch)
        f[:] = 0.0
        f[L.F_T0] = ep.epoch
        x = np.asarray(ep.x0, dtype=float)
        f[L.F_X : L.F_X + 6] = x
        f[L.F_XE : L.F_XE + 6] = x + gen.standard_normal(6) * self._sigma0
        p[...] = self._p0
        f[L.F_Q : L.F_Q + 4] = qt.normalize(gen.normal(size=4))
        rng[:] = crng.seed_state(gen)
        if cfg.image_success_min < 1.0:
            # Drawn last, so the rest of the episode is the one the same seed gives without failures.
            p_fix = gen.uniform(cfg.image_success_min, 1.0, cfg.n_planets)
            f[L.F_IMG_P : L.F_IMG_P + cfg.n_planets] = p_fix
        world = cfg.world
        if world.centroid_bias_bound > 0.0:
            scale = gen.uniform(0.0, world.centroid_bias_bound, cfg.n_planets)
            f[L.F_COB : L.F_COB + cfg.n_planets] = scale
        if world.pulsar_frequency_error_bound > 0.0:
            top = world.pulsar_frequency_error_bound
            delta = gen.uniform(-top, top, cfg.n_pulsars)
            f[L.F_PSR_DRIFT : L.F_PSR_DRIFT + cfg.n_pulsars] = SPEED_OF_LIGHT_KM_S * delta
        if cfg.prior_long_sigma_km > 0.0:
            self._elongate_prior(gen, f, p)
        world = cfg.world
        c_r = 0.5 * (world.reflectivity_range[0] + world.reflectivity_range[1])
        if world.srp_on:
            # Drawn after every other draw: a world without SRP draws nothing new.
            c_r = gen.uniform(*world.reflectivity_range)
            f[L.F_SRP_K] = srp_gm(world.area_to_mass_m2_kg, c_r)
        ops = cfg.operations
        if ops is not None and world.thrust_gauss_markov_on:
            # The execution error's stationary start (magnitude fraction, two pointing angles [rad]).
            sig = np.array([ops.thrust_mag_sigma, *(2 * [math.radians(ops.thrust_point_sigma_deg)])])
            f[L.F_THR_GM : L.F_THR_GM + 3] = sig * gen.standard_normal(3)
        if world.process_noise_tuned:
            a_omit = float(np.linalg.norm(self.omitted_acceleration(ep.epoch, x)))
            f[L.F_Q_PSD] = tuned_accel_psd(a_omit, episode_duration_s(cfg), cfg.filter.accel_psd)
        if world.lambert_cob_corrected:
            # The onboard photometric model's scale 1 + e per planet, e uniform in [-b, b]; drawn after
            # every other draw, so a world without it draws nothing new.
            b = world.cob_model_error
            f[L.F_COB_MODEL : L.F_COB_MODEL + cfg.n_planets] = 1.0 + gen.uniform(-b, b, cfg.n_planets)
        if world.attitude_world_on:
            # The attitude loop's episode: the SRP torque's reflectivity (the force's draw, else
            # mid-range) and the gyro's bias, drawn last (a world without it draws nothing new).
            f[L.F_SRP_CR] = c_r
            if world.gyro_bias_rad_s > 0.0:
                f[L.F_GB : L.F_GB + 3] = world.gyro_bias_rad_s * gen.standard_normal(3)
        return RowEpisode(ep.epoch, ep.central, tuple(ep.perturbers))

    def omitted_acceleration(self, epoch: float, x: np.ndarray) -> np.ndarray:
        """(3,) [km/s^2] the acceleration the filter's force model omits at the state ``x`` (central-body
        frame [km]) at ``epoch`` [TDB s]: the truth's field (its third bodies, and SRP with the top of the
        reflectivity range: the filter does not know the episode's draw) minus the filter's. Zero when
        the truth flies the filter's model."""
        if self.truth_gravity is None:
            return np.zeros(3)
        central = self.plan.central_body
        t = np.array([float(epoch)])
        r = np.asarray(x, dtype=float)[None, :3]

        def rel(eph: DEEphemeris, bodies: tuple[str, ...]) -> np.ndarray | None:
            c = eph.position(central, t)[0] if central != "sun" else np.zeros(3)
            return np.stack([eph.position(b, t)[0] - c for b in bodies]) if bodies else None

        truth, onboard = self.truth_gravity, self.gravity
        a = truth.acceleration(r, rel(self._truth_ephemeris, truth.perturbers))
        a = a - onboard.acceleration(r, rel(self._ephemeris, onboard.perturbers))
        world = self.config.world
        if world.srp_on:
            # Away from the Sun (the heliocentric origin, or the Sun among the approach's perturbers).
            sun = -self._truth_ephemeris.position(central, t)[0] if central != "sun" else np.zeros(3)
            s = r[0] - sun
            k = srp_gm(world.area_to_mass_m2_kg, world.reflectivity_range[1])
            a[0] += k * s / np.linalg.norm(s) ** 3
        return a[0]

    def true_image_success(self) -> np.ndarray:
        """(N, P) each row's probability that an image of planet p in view yields a fix this episode (1
        without failures): the event's realization, privileged (the oracle reference reads it; agents and
        learners do not)."""
        n_p = self.config.n_planets
        if self.config.image_success_min >= 1.0:
            return np.ones((self.num_rows, n_p))
        return self.f[:, L.F_IMG_P : L.F_IMG_P + n_p].copy()

    def true_centroid_bias(self) -> np.ndarray:
        """(N, P) each row's centroid-bias scale of each planet this episode (0 without the event):
        privileged, as :meth:`true_image_success`."""
        n_p = self.config.n_planets
        if self.config.world.centroid_bias_bound <= 0.0:
            return np.zeros((self.num_rows, n_p))
        return self.f[:, L.F_COB : L.F_COB + n_p].copy()

    def _elongate_prior(self, gen: np.random.Generator, f: np.ndarray, p: np.ndarray) -> None:
        """The prior of a row (its float state ``f`` and covariance ``p``) made long along a direction
        ``u`` drawn uniformly on the sphere (``EnvConfig.prior_long_sigma_km``): ``P_rr = s^2 I +
        (L^2 - s^2) u u^T`` with ``s`` the spherical sigma, and the initial error already drawn from
        ``s^2 I`` plus ``sqrt(L^2 - s^2) z u`` (``z`` standard normal), whose covariance is that ``P_rr``.
        Drawn after everything else, so the episode is the one the same seed gives with the spherical
        prior, plus the long error."""
        u = gen.standard_normal(3)
        # Scalar arithmetic, not np.linalg.norm (a BLAS dot): the same bits on every CPU.
        u /= math.sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
        s2 = self._sigma0[0] ** 2
        extra = self.config.prior_long_sigma_km**2 - s2
        f[L.F_XE : L.F_XE + 3] += math.sqrt(extra) * gen.standard_normal() * u
        p[:3, :3] += extra * np.outer(u, u)

    def true_pulsar_drift(self) -> np.ndarray:
        """(N, Q) each row's range drift [km/s] of each pulsar's phases this episode, ``c * delta`` of the
        timing model's frequency error (0 without the event): privileged, as :meth:`true_image_success`."""
        n_q = self.config.n_pulsars
        return self.f[:, L.F_PSR_DRIFT : L.F_PSR_DRIFT + n_q].copy()

    def step_decision(
        self,
        actions: np.ndarray,
        active: np.ndarray | None = None,
        on_step: Callable[[np.ndarray], None] | None = None,
    ) -> None:
        """One decision, :meth:`step`; with ``on_step(stepped)``, the same decision one physics step a call
        of the compiled rule, ``on_step`` running after every physics step with the bool (N,) mask of the
        rows it advanced (evaluation records each physics step)."""
        if on_step is None:
            self.step(actions, active)
            return
        for s in range(self.config.decision_steps):
            before = self.i[:, L.I_K].copy()
            self._run(actions, active, s == 0, 1)
            stepped = self.i[:, L.I_K] != before
            if s > 0 and not stepped.any():
                break
            on_step(stepped)

    def step(self, actions: np.ndarray, active: np.ndarray | None = None) -> None:
        """Advance the ``active`` rows (all by default) by one decision with ``actions`` (N, A) float64,
        the rows' validated actions as given (A = 1 in target mode: the action index; the Box action
        otherwise), decoded by the compiled rule (:mod:`planetnav_env.core.decoding`) with each row's
        current target. The decision rule is compiled (:func:`~planetnav_env.core.kernels.decide_row`):
        ``decision_steps`` physics steps with the same decoded action, the rewards summed into the reward
        column, a row whose episode ends inside the hold stopping there (its flags stay as that step set
        them)."""
        self._run(actions, active, True, self.config.decision_steps)

    def _run(self, actions: np.ndarray, active: np.ndarray | None, first: bool, steps: int) -> None:
        """``steps`` physics steps of the decision rule (``first``: they start the decision), then the
        rows' status codes as named errors."""
        # Plain arrays, not the RowState/Actions records: typing a record passed from Python costs
        # several µs a call (K.step_range_arrays builds them in compiled code).
        # One array type per argument, whatever the caller holds: numba compiles the step once per
        # combination of layouts and read-only flags (minutes each), for the same arithmetic.
        actions = _kernel_array(actions, np.float64)
        active = self._all if active is None else _kernel_array(active, np.bool_)
        state = (self.f, self.p, self.i, self.rng, self.eph, self.obs)
        args = (self.params, *state, actions, self._targets, self._torques, active)
        n = self.num_rows
        if self.threads > 1:
            # The kernels release the GIL; rows are independent, so the chunking changes no result.
            if self._pool is None:
                self._pool = ThreadPoolExecutor(self.threads, thread_name_prefix="planetnav-core")
            c = self.threads
            jobs = [
                self._pool.submit(K.step_range_arrays, *args, j * n // c, (j + 1) * n // c, first, steps)
                for j in range(c)
            ]
            for job in jobs:
                job.result()
        else:
            K.step_range_arrays(*args, 0, n, first, steps)
        status = self.i[:, L.I_STATUS]
        if status.any():
            bad = np.flatnonzero(status)
            r = int(bad[0])
            what = {
                L.STATUS_ATTITUDE_NONFINITE: "the attitude state became non-finite",
                L.STATUS_CAMERA: "the camera geometry is invalid (inside a body, or a non-finite position)",
            }.get(int(status[r]), f"status {int(status[r])}")
            raise NonFiniteError(
                f"row {r} (of rows {bad.tolist()}) at step {int(self.i[r, L.I_K])}: {what}; "
                f"q={self.f[r, L.F_Q : L.F_Q + 4]}, omega={self.f[r, L.F_W : L.F_W + 3]}"
            )

    # ------------------------------------------------------------------------------------------
    def time_s(self, row: int) -> float:
        """Ephemeris time [s] of the row's current step."""
        return _time_s(float(self.f[row, L.F_T0]), int(self.i[row, L.I_K]), self.config.step_s)

    def info_row(self, row: int) -> dict:
        """The ``info`` of one row as the single environment reports it (see PlanetNavEnv), with the
        numeric codes the vector environment also reports: ``target_index`` (index into ``planets +
        pulsars``, -1: none) and ``visibility_code`` (index into
        :data:`planetnav_env.core.layout.REASONS`)."""
        f = self.f[row]
        # One tolist per state row: Python floats / ints equal to float(f[k]) / int(i[k]), without a
        # numpy scalar per key (the single env builds this every step).
        fl, il = f.tolist(), self.i[row].tolist()
        cfg = self.config
        target = il[L.I_TARGET]
        reason = il[L.I_REASON]
        names = cfg.planets + cfg.pulsars
        info = {
            "pos_err_km": fl[L.F_POS_ERR],
            "vel_err_km_s": fl[L.F_VEL_ERR],
            "nees": fl[L.F_NEES],
            "pos_sigma_km": fl[L.F_POS_SIGMA],
            "measured": bool(il[L.I_MEASURED]),
            "rejected": bool(il[L.I_REJECTED]),
            "target": names[target] if target >= 0 else None,
            "target_index": target,
            "sensor": L.SENSORS[il[L.I_SENSOR]],
            "ambiguous_skipped": il[L.I_SKIPPED],
            "visibility": L.REASONS[reason],
            "visibility_code": reason,
            "slewing": bool(il[L.I_SLEWING]),
            "attitude_err_arcsec": attitude_err_arcsec(fl[L.F_ATT_ERR]),
            "time_s": _time_s(fl[L.F_T0], il[L.I_K], cfg.step_s),
            "filter": {"x": f[L.F_XE : L.F_XE + 6].copy(), "P": self.p[row].copy()},
        }
        if cfg.operations is not None:
            ops = self._operations_info(row)
            info.update({k: (float(v[0]) if v.ndim == 1 else v[0]) for k, v in ops.items()})
        return info

    def _operations_info(self, rows: int | slice) -> dict[str, np.ndarray]:
        """The operations keys (docs/environment.md, "Info keys") of ``rows`` as arrays: ``dv_lost_m_s``
        (delta-v lost so far [m/s]), ``deadline_sigma_km`` and ``deadline_err_km`` (per deadline, 0 until
        reached: the position 1-sigma coasted to the encounter and the true mapped error [km], > 0 once
        reached; not NaN, which Gymnasium's checker cannot compare) and ``objective`` (J so far [km] =
        sum of the reached deadline terms + w * dv_lost)."""
        f = self.f[rows] if isinstance(rows, slice) else self.f[rows : rows + 1]
        n_dl = len(self.config.operations.deadlines_s)
        return {
            "dv_lost_m_s": f[:, L.F_DV_LOST].copy(),
            "deadline_sigma_km": f[:, L.F_DL_SIGMA : L.F_DL_SIGMA + n_dl].copy(),
            "deadline_err_km": f[:, L.F_DL_ERR : L.F_DL_ERR + n_dl].copy(),
            "objective": f[:, L.F_OBJECTIVE].copy(),
        }

    def info_batch(self) -> dict[str, np.ndarray]:
        """Per-row quantities as arrays (the vector environment's ``info``): numbers only, so that a step
        of 4096 rows does not build thousands of Python objects. ``target_index`` indexes
        ``config.planets + config.pulsars`` (-1: none); ``visibility_code`` indexes
        :data:`planetnav_env.core.layout.REASONS`. The filter's estimate and covariance are
        :meth:`filter_state` (copying 4096 covariances every step would cost more than the step)."""
        return self.info_batch_columns()[0]

    def info_batch_columns(self) -> tuple[dict[str, np.ndarray], np.ndarray, np.ndarray]:
        """:meth:`info_batch`'s dict and the columns it was built from, ``(info, fc, ic)``: ``fc``
        (len(INFO_F), N) float64 holds the state columns :data:`INFO_F` names (row ``FC_*``), ``ic``
        (len(INFO_I), N) int64 those :data:`INFO_I` names (row ``IC_*``); the vector environment reads
        its other keys from them. Both are new arrays (one gather per state array instead of a copy
        per key: fewer numpy calls at small N) and the values are rows of them, so nothing handed out
        aliases the state a later step overwrites."""
        # take along the columns then a C-order copy of the transpose: each key a contiguous row, one
        # gather per state array.
        fc = self.f.take(INFO_F, axis=1).T.copy()
        ic = self.i.take(INFO_I, axis=1).T.copy()
        flags = ic[_INFO_FLAGS].astype(np.bool_)  # != 0, in one call
        info = {
            "pos_err_km": fc[FC_POS_ERR],
            "vel_err_km_s": fc[FC_VEL_ERR],
            "nees": fc[FC_NEES],
            "pos_sigma_km": fc[FC_POS_SIGMA],
            "measured": flags[0],
            "rejected": flags[1],
            "target_index": ic[IC_TARGET],
            "visibility_code": ic[IC_REASON],
            "slewing": flags[2],
            "time_s": _time_s(fc[FC_T0], ic[IC_K], self.config.step_s),
        }
        if self.config.operations is not None:
            info.update(self._operations_info(slice(None)))
        return info, fc, ic

    def filter_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of every row's filter estimate (N, 6) [km, km/s] and covariance (N, 6, 6)."""
        return self.f[:, L.F_XE : L.F_XE + 6].copy(), self.p.copy()

    def truth_row(self, row: int) -> dict[str, np.ndarray]:
        f = self.f[row]
        return {
            "x": f[L.F_X : L.F_X + 6].copy(),
            "q": f[L.F_Q : L.F_Q + 4].copy(),
            "omega": f[L.F_W : L.F_W + 3].copy(),
            "h_w": f[L.F_HW : L.F_HW + 3].copy(),
        }

    def body_positions(self, row: int) -> dict[str, np.ndarray]:
        """Heliocentric positions [km] of the central body and the planets at the row's current time
        (for rendering and analysis), from the row's table."""
        from planetnav_env.core.ephemeris_table import evaluate

        t = self.time_s(row)
        vals = evaluate(self.eph[row], float(self.f[row, L.F_T0]), self.table_spec.segment_s, np.array([t]))[
            0
        ]
        plan = self.plan
        central = vals[plan.central] if plan.central >= 0 else np.zeros(3)
        return {"central": central, "planets": vals[plan.planet0 : plan.planet0 + len(plan.planets)]}

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_pool"] = None  # threads are not state: a copy starts its own
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        read_only(self.params.stars)  # unpickled arrays come back writable (see read_only)
