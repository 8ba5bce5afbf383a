"""Greedy information agent: look where a measurement would shrink the position covariance most.

Each step, for every planet the camera could see if pointed at it (the observation's "observable if
pointed at" flag), the agent predicts the filter's position covariance after looking at that planet for
a short horizon and picks the largest reduction of ``trace(P_rr)`` per step:

1. Prediction: the environment core's own measurement model, noise and update
   (:func:`planetnav_env.core.what_if.predicted_planet_trace` on copies of ``info["filter"]``), with the
   line-of-sight basis of the predicted direction; no second implementation of the Kalman update.
2. Slew time lost: the angle between the current boresight (star-tracker quaternion x body +x) and the
   planet's estimated direction gives a bang-bang (trapezoidal: torque limit, wheel momentum cap) slew time
   at the mean moment of inertia, stretched by :data:`PD_SLOWDOWN` because the PD law is slower than
   bang-bang. Steps lost = ``ceil(t / step_s) - 1`` (the measurement is taken at the end of a step, so a
   slew shorter than one step loses nothing). Calibrated on 130 random-cruise slews (``docs/agents.md``):
   slews under ~55 deg lose 0 steps, 60-120 deg lose 1-3, 130-170 deg 2-4 (up to 7 near 180 deg, where
   the PD law's error signal ``2 sin(angle)`` vanishes).
3. Over a horizon of ``horizon`` steps the planet is measured ``n = horizon - lost`` times; with the state
   nearly static over the horizon (process noise ~1e-20 km^2/s^3) ``n`` identical measurements equal one
   with covariance ``R / n``, so the predicted covariance is one Kalman update,
   ``P+ = P - P H^T (H P H^T + R/n)^-1 H P``.

Why a horizon and not one step: one measurement barely moves ``P`` (4.6 arcsec at 0.3 AU is ~1000 km),
so a one-step comparison is dominated by the lost step and never switches; over the horizon the value of
a new line of sight (the range along the current one is unobserved) outweighs the slew.

In the default cruise this alternates between Venus and the other planets: the different lines of sight
triangulate the position, which staring at one planet (the baseline) cannot.

With a pulsar detector (``MarsApproach-Tasking``), each observable pulsar whose cycle count the filter
can trust (``ambiguity_k_sigma`` predicted sigmas < half a cycle) is scored by the reduction of one phase
update (``H = n / lambda``, ``R = sigma_phase^2``) divided by its cycle (slew + integration steps); a planet's
score is divided by the horizon. An integration under way is always finished.

``lookahead_s`` (default 0) scores the position covariance coasted that far ahead instead of the current
one (``r + T v``: velocity information counts): a velocity-aware variant. The default 0 scores the current
covariance: no lookahead lowered the day's mean 1σ on the default or the random cruise.

``success`` (tasks with image-processing failures, ``EnvConfig.image_success_min``): how the score of a
planet counts images that yield no fix. ``nominal`` (default): the filter's model, every image succeeds.
``observed``, the adaptive rule: each planet's score times the mean of its success rate under a uniform
prior updated by this episode's images (the observation's ``image_log`` block; what the spacecraft knows).
``oracle``: times the true rate drawn for the episode (privileged: a reference that knows the event's
realization, reported as an upper bound, never used as the score's best reference).

``bias`` (tasks with a centroid bias, ``world.centroid_bias_max``): how the score of a planet counts
a bias the filter does not model. ``nominal`` (default): none. ``observed``, the adaptive rule: each planet's
score divided by the mean normalized NIS of its fixes this episode (the observation's ``residual_log``;
1 for a consistent beacon), so a beacon whose residuals disagree with the filter is down-weighted.
``expected``: divided by ``1 + (delta / sigma)^2``, with ``delta`` the offset an image of it would have now at
the prior mean scale ``world.centroid_bias_max / 2`` (the bias model is known, its size is not; phase angle
and apparent diameter from the estimate) and ``sigma`` the filter's direction sigma. ``oracle``: the same with
the planet's true drawn scale (privileged). ``photometric`` (the flight world, whose onboard photometric model
takes the Lambertian centre of brightness off each image with a scale error it does not know,
``world.cob_model_error``): divided by ``1 + (delta / sigma)^2``, with ``delta`` the residual that error's
rms (bound / sqrt 3, the error uniform) would leave on an image of the planet now, at the phase angle and
apparent radius from the estimate and the onboard ephemeris. It knows the model's error bound, not its draw.

``timing`` (tasks with a pulsar timing-model error, ``world.pulsar_frequency_error_max``): how the
score of a pulsar counts a phase drift the filter does not model. ``nominal`` (default): none. ``observed``,
the adaptive rule: each pulsar's score divided by the mean normalized NIS of its phases this episode (the
observation's ``residual_log``), as ``bias=observed`` does for planets. ``oracle``: divided by
``1 + (d / sigma)^2``, with ``d`` the pulsar's true range error now (its drawn drift times the time since the
episode's start) and ``sigma`` the range sigma a phase of it would have (its noise and the filter's range
sigma along the pulsar): privileged.

``threshold`` θ (operations scenarios only, ``greedy:threshold=1``): the deadline- and cost-aware session
rule of :mod:`planetnav_agents.operations` instead (sessions of ``session`` steps, default 2 h; stay at the
mission attitude otherwise). Without it, greedy is unchanged.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np

from planetnav_agents.base import ParsedObservation, TargetAgent
from planetnav_agents.gain import DEFAULT_HORIZON, PD_SLOWDOWN, SlewModel, lost_steps, planet_scores
from planetnav_agents.operations import DeadlineSessionRule
from planetnav_env.astro.bodies import body
from planetnav_env.core import layout as L
from planetnav_env.core.decisions import RESIDUAL_CAP
from planetnav_env.core.what_if import coasted_position_trace, predicted_planet_trace, predicted_pulsar_trace
from planetnav_env.sensors.camera_kernels import centroid_offset
from planetnav_env.sensors.photometry import lambert_cob_offset
from planetnav_env.sensors.pulsar import ambiguity_resolvable_kernel

#: How greedy counts images that yield no fix (the ``success`` option; module docstring).
SUCCESS_MODELS = ("nominal", "observed", "oracle")
#: How greedy counts a centroid bias (the ``bias`` option; module docstring).
BIAS_MODELS = ("nominal", "expected", "observed", "oracle", "photometric")
#: How greedy counts a pulsar timing-model error (the ``timing`` option; module docstring).
TIMING_MODELS = ("nominal", "observed", "oracle")


def _phase_and_radius(
    sc: np.ndarray, planets: np.ndarray, radii: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The cosine of each planet's phase angle (Sun-planet-spacecraft) and its apparent radius [rad], (P,)
    each, from the spacecraft's position ``sc`` (3,) and the planets' ``planets`` (P, 3), both
    heliocentric [km], and the planets' radii (P,) [km]: the geometry the rules read from the estimate."""
    to_sun = -planets / np.linalg.norm(planets, axis=1, keepdims=True)
    rel = sc - planets
    dist = np.linalg.norm(rel, axis=1)
    cos_phase = np.sum(to_sun * (rel / dist[:, None]), axis=1)
    return cos_phase, np.arcsin(np.minimum(radii / dist, 1.0))


def _check_model(option: str, value: str, models: tuple[str, ...], block: str, observed: bool) -> None:
    """ValueError naming ``option`` when ``value`` is not one of ``models``, or is ``observed`` while the
    environment's observation has no ``block`` (``observed`` False)."""
    if value not in models:
        raise ValueError(f"greedy: {option} must be one of {list(models)}, got {value!r}")
    if value == "observed" and not observed:
        raise ValueError(
            f"greedy: {option}='observed' reads the observation's {block} block, which this environment does "
            f"not have (observe_{block} false)"
        )


def _mean_nis_at_least_one(residual_log: np.ndarray) -> np.ndarray:
    """Per target, ``max(mean normalized NIS, 1)`` from the observation's residual log (the mean divided by
    RESIDUAL_CAP): what the adaptive rules divide a beacon's score by (1 for a beacon consistent with the
    filter)."""
    return np.maximum(np.asarray(residual_log, dtype=float) * RESIDUAL_CAP, 1.0)


class GreedyAgent(TargetAgent):
    """Largest predicted reduction of ``trace(P_rr)`` over ``horizon`` steps, slew time counted."""

    name = "greedy"
    requires_idle_action = False

    def __init__(
        self,
        env: gym.Env,
        horizon: int = DEFAULT_HORIZON,
        pd_slowdown: float = PD_SLOWDOWN,
        lookahead_s: float = 0.0,
        threshold: float | None = None,
        session: int | None = None,
        success: str = "nominal",
        bias: str = "nominal",
        timing: str = "nominal",
    ) -> None:
        super().__init__(env)
        _check_model("success", success, SUCCESS_MODELS, "image_log", self.config.observe_image_log)
        _check_model("bias", bias, BIAS_MODELS, "residual_log", self.config.observe_residual_log)
        _check_model("timing", timing, TIMING_MODELS, "residual_log", self.config.observe_residual_log)
        if timing != "nominal" and not self.config.pulsars:
            raise ValueError(f"greedy: timing={timing!r} scores pulsars, and this environment has none")
        if bias in ("oracle", "expected") and self.config.scenario == "mars-approach":
            raise ValueError(
                f"greedy: bias={bias!r} needs a heliocentric scenario (the cruises), not mars-approach"
            )
        if bias == "photometric" and not self.config.world.lambert_cob_corrected:
            raise ValueError(
                "greedy: bias='photometric' scores the onboard photometric model's error, and this "
                "environment's world has none (world.lambert_cob off)"
            )
        self.success, self.bias, self.timing = success, bias, timing
        models = {"success": success, "bias": bias, "timing": timing}
        parts = [f"{k}={v}" for k, v in models.items() if v != "nominal"]
        if parts:
            self.name = "greedy:" + ",".join(parts)
        # Operations scenarios: the deadline- and cost-aware session rule (planetnav_agents.operations).
        self.sessions = None
        if threshold is not None or session is not None:
            if threshold is None:
                raise ValueError(f"greedy: session={session!r} needs threshold=<theta> (operations)")
            self.sessions = DeadlineSessionRule(env, threshold, session)
            self.name = f"greedy:threshold={threshold:g}" + (f",session={session}" if session else "")
        if horizon < 1:
            raise ValueError(f"horizon must be >= 1 step, got {horizon}")
        if isinstance(lookahead_s, bool) or not (
            isinstance(lookahead_s, int | float) and math.isfinite(lookahead_s) and lookahead_s >= 0
        ):
            raise ValueError(f"lookahead_s must be a finite number of seconds >= 0, got {lookahead_s!r}")
        self.horizon = int(horizon)
        self.lookahead_s = float(lookahead_s)
        cfg = self.config
        # The environment's own parameter record: the what-if updates use the core's model and noise.
        self._params = env.unwrapped.core_params
        self._integration_steps = max(1, math.ceil(cfg.detector.integration_time_s / cfg.step_s - 1e-9))
        self.slew = SlewModel.from_config(cfg, pd_slowdown)
        self._radii = np.array([body(p).radius for p in cfg.planets])
        self.last_scores: np.ndarray = np.zeros(cfg.n_targets)

    def lost_steps(self, angle_rad: np.ndarray) -> np.ndarray:
        """Predicted steps without a measurement while slewing through ``angle_rad``."""
        s = self.slew
        return lost_steps(np.asarray(angle_rad, dtype=float), s.accel, s.rate_max, s.pd_slowdown, s.step_s)

    def trace_now(self, p: np.ndarray) -> float:
        """The score's ``trace(P_rr)`` [km^2] of covariance ``p`` with no measurement (coasted
        ``lookahead_s`` ahead, ``core.what_if.coasted_position_trace``)."""
        return float(coasted_position_trace(np.ascontiguousarray(p, dtype=float), self.lookahead_s))

    def predicted_trace(self, x: np.ndarray, p: np.ndarray, planet: np.ndarray, i: int, n: int) -> float:
        """``trace(P_rr)`` after ``n`` measurements of planet ``i`` (at ``planet``) from estimate ``x``:
        the environment core's own measurement model and update (``core.what_if.predicted_planet_trace``)."""
        if n <= 0:
            return self.trace_now(p)
        return float(
            predicted_planet_trace(
                self._params, x, p, np.asarray(planet, float), int(i), float(n), self.lookahead_s
            )
        )

    def pulsar_trace(self, p: np.ndarray, n_dir: np.ndarray, j: int) -> float:
        """``trace(P_rr)`` after one phase of pulsar ``j``: the core's scalar update
        (``core.what_if.predicted_pulsar_trace``; ``H = n / lambda``, ``R = sigma_phase^2``)."""
        p = np.ascontiguousarray(p, dtype=float)
        return float(predicted_pulsar_trace(self._params, p, int(j), self.lookahead_s))

    def _planet_scores(self, obs: ParsedObservation, info: dict[str, Any]) -> np.ndarray:
        """(P,) reduction of trace(P_rr) per step over the horizon [km^2/step], -inf if not observable
        (:func:`planetnav_agents.gain.planet_scores`, the one formula)."""
        x = np.ascontiguousarray(self.estimate(obs, info), dtype=float)
        p = np.ascontiguousarray(info["filter"]["P"], dtype=float)
        out = np.empty((1, self.n_planets))
        planet_scores(
            self._params,
            self.slew,
            self.horizon,
            obs.q[None],
            np.ascontiguousarray(obs.planets[None]),
            x[None],
            p[None],
            out,
            self.lookahead_s,
        )
        return out[0]

    def planet_weights(self, obs: ParsedObservation, info: dict[str, Any]) -> np.ndarray | None:
        """(P,) the factor on each planet's score from ``success`` and ``bias`` (None: both nominal)."""
        if self.success == "nominal" and self.bias == "nominal":
            return None
        w = np.ones(self.n_planets)
        if self.success == "observed":
            w *= np.asarray(obs.block("image_log")[0], dtype=float)
        elif self.success == "oracle":
            w *= self.env.unwrapped.core.true_image_success()[0]
        if self.bias == "observed":
            w /= _mean_nis_at_least_one(obs.block("residual_log")[: self.n_planets])
        elif self.bias in ("oracle", "expected"):
            scale = (
                self.env.unwrapped.core.true_centroid_bias()[0] if self.bias == "oracle"
                else np.full(self.n_planets, 0.5 * self.config.world.centroid_bias_bound)
            )  # fmt: skip
            w /= 1.0 + (self._offsets(obs, info, scale) / float(self._params.scalars[0]["sig_dir"])) ** 2
        elif self.bias == "photometric":
            sigma = float(self._params.scalars[0]["sig_dir"])
            w /= 1.0 + (self._photometric_residuals(obs, info) / sigma) ** 2
        return w

    def _photometric_residuals(self, obs: ParsedObservation, info: dict[str, Any]) -> np.ndarray:
        """(P,) the rms residual [rad] the onboard photometric model's scale error leaves on an image of each
        planet now: ``cob_model_error / sqrt(3)`` times the Lambertian centre-of-brightness offset at the
        phase angle and apparent radius the spacecraft computes (its estimate, the onboard ephemeris)."""
        bodies = self.env.unwrapped.core.body_positions(0)  # heliocentric [km], onboard ephemeris
        sc = bodies["central"] + np.asarray(self.estimate(obs, info), dtype=float)[:3]
        cos_phase, radius = _phase_and_radius(sc, np.asarray(bodies["planets"], dtype=float), self._radii)
        cob = np.array([lambert_cob_offset(float(c)) for c in cos_phase])
        return self.config.world.cob_model_error / math.sqrt(3.0) * cob * radius

    def pulsar_weights(self, obs: ParsedObservation, p: np.ndarray) -> np.ndarray | None:
        """(Q,) the factor on each pulsar's score from ``timing`` (None: nominal); ``p`` the filter's
        covariance (6, 6) [km, km/s]."""
        if self.timing == "nominal":
            return None
        if self.timing == "observed":
            return 1.0 / _mean_nis_at_least_one(obs.block("residual_log")[self.n_planets :])
        core = self.env.unwrapped.core
        elapsed_s = float(core.i[0, L.I_K]) * self.config.step_s
        psr = self._params.psr
        p_rr = np.asarray(p, dtype=float)[:3, :3]
        # The range sigma a phase would have: its noise (wavelength x phase sigma) and the filter's own range
        # uncertainty along the pulsar (a bias well inside what the filter does not know yet is harmless).
        sigma = np.sqrt((psr[:, 3] * psr[:, 4]) ** 2 + np.einsum("qi,ij,qj->q", psr[:, :3], p_rr, psr[:, :3]))
        return 1.0 / (1.0 + (core.true_pulsar_drift()[0] * elapsed_s / sigma) ** 2)

    def _offsets(self, obs: ParsedObservation, info: dict[str, Any], scale: np.ndarray) -> np.ndarray:
        """(P,) the centroid offset [rad] an image of each planet would have now at bias scales ``scale``
        (P,), the phase angle and apparent diameter from the estimate."""
        x = np.asarray(self.estimate(obs, info), dtype=float)
        # heliocentric: the cruise scenarios' frame
        cos_phase, radius = _phase_and_radius(x[:3], obs.planet_positions(x), self._radii)
        alpha = 2.0 * radius
        # The environment's own offset formula, planet by planet (a compiled scalar function).
        rows = zip(scale, alpha, cos_phase, strict=True)
        return np.array([centroid_offset(float(b), float(a), float(c)) for b, a, c in rows])

    def reset(self, seed: int | None = None) -> None:
        if self.sessions is not None:
            self.sessions.reset()

    def choose_target(self, obs: ParsedObservation, info: dict[str, Any]) -> int:
        p = np.asarray(info["filter"]["P"], dtype=float)
        if self.sessions is not None:
            return self.sessions.choose(obs, self.estimate(obs, info), p)
        n_p = self.n_planets
        boresight = obs.boresight_inertial
        trace0 = self.trace_now(p)
        # Scores are covariance reductions per step of the option's own cycle, so that a planet
        # (``horizon`` steps of images) and a pulsar (one phase per integration window) compare.
        scores = np.full(self.n_targets, -np.inf)
        scores[:n_p] = self._planet_scores(obs, info)
        weights = self.planet_weights(obs, info)
        if weights is not None:
            # e.g. expected reduction: a fraction `rate` of the horizon's images give fixes (-inf stays -inf).
            scores[:n_p] = np.where(np.isfinite(scores[:n_p]), scores[:n_p] * weights, -np.inf)
        if obs.pulsars.shape[0]:
            # An integration already under way is finished: leaving loses it.
            if obs.target >= n_p and 0.0 < obs.pulsars[obs.target - n_p, L.TF_PROGRESS] < 1.0:
                self.last_scores = scores
                return obs.target
            n_dirs = obs.pulsar_los_inertial
            psr_lost = self.lost_steps(np.arccos(np.clip(n_dirs @ boresight, -1.0, 1.0)))
            # The environment's own trust rule and its configured k (the filter skips untrusted phases).
            resolvable = ambiguity_resolvable_kernel(
                10.0 ** obs.pulsars[:, L.TF_LOG_PHASE_SIGMA], self.config.ambiguity_k_sigma
            )
            for j in np.flatnonzero((obs.pulsars[:, L.TF_OBSERVABLE] > 0.5) & resolvable):
                cycle = self._integration_steps + int(psr_lost[j])
                scores[n_p + j] = (trace0 - self.pulsar_trace(p, n_dirs[j], int(j))) / cycle
            pw = self.pulsar_weights(obs, p)
            if pw is not None:
                scores[n_p:] = np.where(np.isfinite(scores[n_p:]), scores[n_p:] * pw, -np.inf)
        self.last_scores = scores
        if not np.any(np.isfinite(scores)):
            # Nothing observable: keep the current target (the camera waits pointed where it was).
            return obs.target if obs.target >= 0 else 0
        return int(np.argmax(scores))


#: The ``greedy-pd`` agent's horizon [s]: greedy's default of DEFAULT_HORIZON steps at the cruise's 60-s
#: step, kept in time when the step is shorter (at 1 s a 3-step horizon never outweighs a ~100-s slew).
GREEDY_PD_HORIZON_S = 180.0


def greedy_pd(
    env: gym.Env,
    horizon_s: float = GREEDY_PD_HORIZON_S,
    pd_slowdown: float = PD_SLOWDOWN,
    lookahead_s: float = 0.0,
) -> GreedyAgent:
    """Greedy + PD, the reference of the wheel-torque tasks: greedy's target choice over a
    horizon of ``horizon_s`` seconds (``round(horizon_s / step_s)`` steps, at least 1), executed by the PD
    law: the env's own in ``target`` and ``hybrid`` mode (its PD option), the agent-side
    :class:`~planetnav_agents.base.PointingLaw` as wheel torques in ``torque`` mode (at a 1-s step the
    env's gains on the star-tracker attitude and reported rates)."""
    if not (isinstance(horizon_s, int | float) and math.isfinite(horizon_s) and horizon_s > 0):
        raise ValueError(f"horizon_s must be a positive number of seconds, got {horizon_s!r}")
    step_s = float(env.unwrapped.config.step_s)
    agent = GreedyAgent(
        env, horizon=max(1, round(horizon_s / step_s)), pd_slowdown=pd_slowdown, lookahead_s=lookahead_s
    )
    agent.name = "greedy-pd"
    return agent
