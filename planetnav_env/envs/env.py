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

The environment is a shell over :class:`planetnav_env.batch.BatchCore` with one row: the vector
environment (:class:`planetnav_env.envs.vector_env.PlanetNavVectorEnv`) runs the same compiled step over N
rows, and row i of it equals this environment seeded ``seed + i`` bit for bit.

Simplification: the PD law runs on the true attitude inside the sub-steps (its error, a few arcsec
from the star tracker, is far below what changes a slew); the target direction it tracks comes from
the *estimated* position.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.envs.registration import EnvSpec

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.layout import ObservationLayout
from planetnav_env.core.rng import seed_state
from planetnav_env.envs.registration import id_options
from planetnav_env.envs.spaces import (
    action_size,
    action_space,
    check_box_actions,
    check_target_actions,
    decode_observation,
    format_observation,
    observation_space,
)
from planetnav_env.errors import ConfigError, InvalidParameterError

#: The per-physics-step values :attr:`PlanetNavEnv.held` holds after a step when ``decision_steps`` > 1
#: (each (k,), the k physics steps the decision ran): what an evaluation that averages over physics steps
#: reads (``info`` is the last physics step's, as in the vector environment).
DECISION_KEYS = ("pos_err_km", "pos_sigma_km", "vel_err_km_s", "measured", "slewing")


def resolve_config(config: EnvConfig | Mapping | str | None, overrides: dict[str, Any]) -> EnvConfig:
    """An ``EnvConfig`` from a config, a mapping, a registered id (``"planetnav/Cruise-Target-v0"``: its
    options, as ``gym.make`` passes them) or None, with keyword overrides (named errors)."""
    if isinstance(config, EnvConfig):
        return EnvConfig.from_dict(config.to_dict(), **overrides) if overrides else config
    if isinstance(config, str):
        config = id_options(config)
    elif config is not None and not isinstance(config, Mapping):
        raise ConfigError(
            "config must be an EnvConfig, a mapping of options, a planetnav environment id or None, "
            f"got {config!r} of type {type(config).__name__}"
        )
    return EnvConfig.from_dict(config or {}, **overrides)


def check_reset_options(options: Any, known: tuple[str, ...], owner: str) -> None:
    """Raise :class:`~planetnav_env.errors.InvalidParameterError` naming any key of ``options`` that
    ``owner`` does not know (a misspelt option must not be ignored in silence)."""
    if options is None:
        return
    if not isinstance(options, Mapping):
        raise InvalidParameterError(
            f"{owner}.reset options must be a dict or None, got {options!r} of type {type(options).__name__}"
        )
    unknown = sorted(str(k) for k in options if k not in known)
    if unknown:
        accepted = f"known reset options: {list(known)}" if known else "it takes no reset options"
        raise InvalidParameterError(f"{owner}.reset got unknown option(s) {unknown}; {accepted}")


def spec_with_episode_length(spec: EnvSpec | None, episode_steps: int) -> EnvSpec | None:
    """``spec`` with ``max_episode_steps`` set to the environment's own truncation length when it has
    none. ``gym.make`` gives the unwrapped env a spec with ``None`` there (and the registry keeps
    ``None`` so that no ``TimeLimit`` counts the steps a second time); clients read the episode length
    from ``env.spec.max_episode_steps``."""
    if spec is None or spec.max_episode_steps is not None:
        return spec
    return dataclasses.replace(spec, max_episode_steps=int(episode_steps))


class EpisodeLengthSpec:
    """Mixin of the single and the vector environment: their ``spec`` (set by ``gym.make`` /
    ``gym.make_vec``) reads ``max_episode_steps`` = the config's ``episode_steps``."""

    _spec: EnvSpec | None = None
    config: Any

    @property
    def spec(self) -> EnvSpec | None:
        """The spec the registry gave this environment, with ``max_episode_steps`` = the decisions of an
        episode (``episode_steps``, or fewer with ``decision_steps`` > 1)."""
        return self._spec

    @spec.setter
    def spec(self, value: EnvSpec | None) -> None:
        self._spec = spec_with_episode_length(value, self.config.episode_decisions)


class PlanetNavEnv(EpisodeLengthSpec, gym.Env):
    """Autonomous optical navigation between the planets (see the module docstring for one step).

    Action spaces (``action_mode``)
    -------------------------------
    ============== ======================================== ==========================================
    mode           space                                    meaning
    ============== ======================================== ==========================================
    target         ``Discrete(n_planets)``                  planet index (order of ``planets``); the
                   (``+1`` "camera off" if ``idle_action``)  thesis's PD law slews to it
    torque         ``Box(-1, 1, (3,))``                     wheel torque / (torque_action_scale x
                                                            torque limit), body axes;
                                                            the camera measures the visible planet
                                                            nearest its boresight
    target+torque  ``Box(-1, 1, (n_planets + 3,))``         ``argmax(a[:n])`` picks the target (PD law
                                                            slews to it); ``a[n:]`` is a residual torque
                                                            (same units as ``torque``) added to the PD
                                                            command. A Box because Stable-Baselines3
                                                            rejects Dict and Tuple action spaces.
    hybrid         ``Box(-1, 1, (n_planets + 1 + 3,))``     option ``k = argmax(a[:n + 1])``: ``k < n``
                                                            the PD law slews to planet k (``a[n + 1:]``
                                                            ignored), ``k = n`` the agent's torque
                                                            ``a[n + 1:]`` (units of ``torque``) drives
                                                            the wheels (``spaces.decode_hybrid``); the
                                                            camera measures the visible planet nearest
                                                            its boresight, as in ``torque``
    ============== ======================================== ==========================================

    ``planetnav/Cruise-TorqueControl-v0`` (torque) and ``planetnav/Cruise-Hybrid-v0`` (hybrid) run at the
    attitude's timescale: 1-s steps for one hour, one unit of torque action = 0.01 N m (the wheel limit),
    and the ``in_field`` observation block (``observe_in_field``).

    Box actions outside [-1, 1] are clipped (SB3 clips to the bounds too); NaN or infinite actions
    raise :class:`~planetnav_env.errors.NonFiniteError`; a discrete action outside its range raises
    :class:`~planetnav_env.errors.InvalidParameterError`. Nothing invalid reaches the physics.

    Observation (``observation="box"``, float32; ``P`` planets, ``Q`` pulsars, ``T = P + Q``)
    ----------------------------------------------------------------------------------------
    {OBSERVATION_TABLE}

    ``observation="dict"`` gives the same quantities under the keys ``position``, ``velocity``,
    ``log_sigma``, ``attitude``, ``rates``, ``wheel_momentum``, ``planets`` (P, 7), ``pulsars``
    (Q, 7; only with pulsars), ``target`` (T,) and ``elapsed`` (1,). :meth:`decode_observation`
    turns either form back into physical units (for rule-based agents). The table above is generated from
    :class:`~planetnav_env.core.layout.ObservationLayout`, which the compiled builders, the spaces and the
    decoder share.

    Reward, termination, info
    -------------------------
    ``reward="truth"``: ``-|r_est - r_true| / reward_scale_km`` per step (privileged: a real
    spacecraft cannot compute it); ``"covariance"``: ``-sqrt(trace P_rr) / reward_scale_km``. Minus
    ``torque_penalty * |u / u_max|^2`` for commanded torques. The episode *terminates* when the true
    position error exceeds ``divergence_km`` or the filter state becomes non-finite (divergence), and
    is *truncated* after ``episode_steps`` (``env.spec.max_episode_steps`` reports it). ``info`` holds
    ``pos_err_km``, ``vel_err_km_s``, ``nees``, ``pos_sigma_km``, ``measured``, ``rejected``, ``target``
    (name or None) and ``target_index`` (-1: none), ``sensor``, ``ambiguous_skipped``, ``visibility``
    (reason) and ``visibility_code``, ``slewing``, ``attitude_err_arcsec`` (star tracker), ``time_s`` and
    ``filter`` (the estimate ``x`` and covariance ``P``, which the spacecraft knows); the vector
    environment gives the same keys as arrays over its rows (docs/environment.md, "Info keys").
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 15}  # noqa: RUF012 (Gymnasium convention)

    def __init__(
        self,
        config: EnvConfig | Mapping | str | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ):
        cfg = resolve_config(config, overrides)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise InvalidParameterError(
                f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        self.config = cfg
        self.render_mode = render_mode
        self.planets = cfg.planets
        self.pulsars = cfg.pulsars
        self.core = BatchCore(cfg, 1)
        self.layout: ObservationLayout = self.core.layout
        self.action_space = action_space(cfg)
        self.observation_space = observation_space(cfg, self.layout)
        self._obs_dim = self.layout.size
        self._raw = np.zeros((1, action_size(self.action_space)))  # the action the core decodes
        self._started = False
        self._done = False
        self.history: list[tuple[float, float]] = []
        #: With ``decision_steps`` > 1: the last decision's physics steps, ``DECISION_KEYS`` -> (k,) arrays.
        self.held: dict[str, np.ndarray] = {}

    # ------------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode (drawn from ``seed`` in the ``random-cruise`` scenario); the environment
        takes no reset options (an unknown one raises, naming it)."""
        check_reset_options(options, (), "PlanetNavEnv")
        super().reset(seed=seed)
        self.core.reset_rows(np.zeros(1, dtype=np.int64), [self.np_random])
        self._started = True
        self._done = False
        info = self.core.info_row(0)
        self.history = [(info["pos_err_km"], info["pos_sigma_km"])]
        return format_observation(self.config, self.layout, self.core.obs[0]), info

    def _check(self, action: Any) -> None:
        """``action`` checked (named errors) into the raw action row the core decodes."""
        cfg = self.config
        if cfg.action_mode == "target":
            n_act = self.action_space.n
            if type(action) is int or isinstance(action, np.integer):  # the common case, checked cheaply
                idx = int(action)
                if not 0 <= idx < n_act:
                    raise InvalidParameterError(
                        f"target action must be an integer in [0, {n_act}), got {action!r}"
                    )
                self._raw[0, 0] = idx
            else:
                self._raw[:, 0] = check_target_actions(cfg, n_act, action, 1, single=True)
            return
        self._raw[:] = check_box_actions(cfg, self.action_space.shape, action, 1, single=True)

    def step(self, action: Any):
        if not self._started:
            raise RuntimeError("call reset() before step()")
        if self._done:
            raise RuntimeError("the episode has ended (terminated or truncated): call reset() before step()")
        self._check(action)
        core = self.core
        if self.config.decision_steps == 1:
            core.step(self._raw)
            info = core.info_row(0)
            self.history.append((info["pos_err_km"], info["pos_sigma_km"]))
        else:
            steps: list[dict[str, Any]] = []
            record = lambda _: steps.append(core.info_batch())  # noqa: E731
            core.step_decision(self._raw, on_step=record)
            info = core.info_row(0)
            self.held = {k: np.array([h[k][0] for h in steps]) for k in DECISION_KEYS}
            self.history += list(zip(self.held["pos_err_km"], self.held["pos_sigma_km"], strict=True))
        terminated = bool(core.i[0, L.I_TERMINATED])
        truncated = bool(core.i[0, L.I_TRUNCATED])
        self._done = terminated or truncated
        obs = format_observation(self.config, self.layout, core.obs[0])
        return obs, float(core.f[0, L.F_REWARD]), terminated, truncated, info

    # ------------------------------------------------------------------------------------------
    def decode_observation(self, observation: Any) -> dict[str, Any]:
        """Named arrays in physical units from a ``box`` or ``dict`` observation of this env:
        position_km, velocity_km_s (relative to the central body), log_sigma (6,), q (star tracker),
        rates_rad_s, wheel_fraction, planets (P, 7) and pulsars (Q, 7) as laid out in the class
        docstring, target (index or -1), elapsed."""
        return decode_observation(self.config, self.layout, observation)

    def render(self) -> np.ndarray | None:
        """The current frame, (480, 1280, 3) uint8 RGB, with ``render_mode="rgb_array"`` (else None): the
        camera view, the error history and the orbit view (see :mod:`planetnav_env.envs.render`)."""
        if self.render_mode != "rgb_array":
            return None
        from planetnav_env.envs.render import render_frame

        return render_frame(self._frame_data())

    def _frame_data(self) -> Any:
        """The :class:`planetnav_env.envs.render.FrameData` of the current state. The env hands render.py
        plain numbers (heliocentric ICRF km), so render.py never imports this module."""
        from planetnav_env.astro.bodies import body
        from planetnav_env.envs.render import FrameData
        from planetnav_env.sensors.pulsar import pulsar
        from planetnav_env.sensors.star_tracker import StarTrackerConfig, catalogue_for

        cfg = self.config
        info = self.core.info_row(0)  # what the last reset/step returned (filter estimate and covariance)
        truth = self.truth
        bodies = self.body_positions()
        central_km = bodies["central"]  # the truth and the filter are relative to the central body
        episodes = getattr(self.core, "episodes", None)
        central = episodes[0].central if episodes and episodes[0] is not None else "sun"
        # The camera's own stars: the core's star tracker uses the default catalogue (core/params.py).
        stars = catalogue_for(StarTrackerConfig()).directions
        hist = np.asarray(self.history, dtype=float).reshape(-1, 2)
        return FrameData(
            title=self.spec.id if self.spec is not None else f"{cfg.scenario} ({cfg.action_mode})",
            time_s=(len(hist) - 1) * float(cfg.step_s),  # info["time_s"] is ephemeris time, not elapsed
            step=len(hist) - 1,
            episode_steps=int(cfg.episode_steps),
            step_s=float(cfg.step_s),
            spacecraft_km=truth["x"][:3] + central_km,
            estimate_km=info["filter"]["x"][:3] + central_km,
            position_cov_km2=info["filter"]["P"][:3, :3],
            central=central,
            planet_names=tuple(self.planets),
            planet_km=np.asarray(bodies["planets"], dtype=float).reshape(-1, 3),
            planet_radii_km=np.array([body(p).radius for p in self.planets], dtype=float),
            pulsar_names=tuple(self.pulsars),
            pulsar_dirs=np.array([pulsar(p).direction for p in self.pulsars], dtype=float).reshape(-1, 3),
            target=info["target"],
            visibility=str(info["visibility"]),
            measured=bool(info["measured"]),
            attitude_q=truth["q"],
            camera=cfg.camera,
            star_dirs=stars,
            history_km=hist,
        )

    @property
    def truth(self) -> dict[str, np.ndarray]:
        """The true state (for analysis, tests and rendering; agents must not read it)."""
        return self.core.truth_row(0)

    @property
    def target_index(self) -> int:
        """Index of the current target (planets, then pulsars) or -1."""
        return int(self.core.i[0, L.I_TARGET])

    def current_observation(self) -> Any:
        """The observation of the current state (what the last ``reset``/``step`` returned)."""
        return format_observation(self.config, self.layout, self.core.obs[0])

    def reseed_noise(self, seed: int) -> None:
        """Replace the sensor-noise stream (star tracker, rates, camera, pulsars) by one seeded with
        ``seed``: planners that roll out copies use it so that a copy never replays the real noise."""
        self.core.rng[0] = seed_state(np.random.default_rng(seed))

    def body_positions(self) -> dict[str, np.ndarray]:
        """Heliocentric positions [km] of the central body and the planets now (from the episode's table)."""
        return self.core.body_positions(0)

    # -- Public accessors for wrappers and agents (``planetnav_agents``) --
    @property
    def core_params(self) -> Any:
        """The compiled parameter record (``CoreParams``) this environment steps with; read-only by
        convention. Agents' what-if kernels (greedy's score, the ``gain`` feature) take it so that their
        predictions use the environment's own measurement model and noise."""
        return self.core.params


PlanetNavEnv.__doc__ = (PlanetNavEnv.__doc__ or "").replace(
    "{OBSERVATION_TABLE}",
    ObservationLayout(3, 0).doc_table().replace("\n", "\n    "),
)
