"""PlanetNavVectorEnv: N environments stepped by one compiled loop over the batch core.

``gym.make_vec("planetnav/<id>", num_envs=N)`` returns it (the ids' ``vector_entry_point``). Row ``i``
after ``reset(seed=s)`` is, bit for bit, the single :class:`~planetnav_env.envs.env.PlanetNavEnv` after
``reset(seed=s + i)``: both run :class:`~planetnav_env.batch.BatchCore`, and each row keeps its own
Gymnasium ``np_random`` (for episode draws) and its own compiled random stream (for sensor noise).

Autoreset: ``autoreset_mode="next_step"`` (Gymnasium's default): the step after a row ends resets it and
returns its first observation with reward 0; ``"same_step"``: a row that ends is reset in the same
step, its last observation in ``info["final_obs"]`` and its last info in ``info["final_info"]`` (what
Stable-Baselines3 expects; :class:`planetnav_train.sb3_vec.PlanetNavSB3VecEnv` uses it); ``"disabled"``
(Gymnasium >= 1.1): no autoreset, the caller resets the rows that ended with
``reset(options={"reset_mask": mask})`` before stepping them again (what TorchRL prefers; its
``GymWrapper`` refuses ``next_step``, see docs/environment.md, "Clients").

``info`` has the single environment's keys, each an array over the rows (Gymnasium's vector convention,
with the ``_key`` masks): numbers as numeric arrays, names (``target``, ``sensor``, ``visibility``) as
object arrays of str or None, and ``filter`` as ``{"x": (N, 6), "P": (N, 6, 6)}``; the table is in
docs/environment.md ("Info keys"). ``info_keys="numeric"`` gives the keys whose values are numbers only,
flat (for clients that turn every info value into a tensor, as TorchRL's ``same_step`` reader does): the
names are left out (``target_index`` and ``visibility_code`` carry two of them as codes) and the filter is
``filter_x`` (N, 6) [km, km/s] and ``filter_P`` (N, 6, 6); ``final_info`` rows take the same form.
:meth:`PlanetNavVectorEnv.info_row` gives one row's info in the single environment's form and
:meth:`PlanetNavVectorEnv.filter_state` the filters.
Bad actions (wrong shape, NaN in a row, out of range) raise before any row is stepped, naming the row.
A row whose filter diverges terminates alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from planetnav_env import batch as B
from planetnav_env.batch import BatchCore, attitude_err_arcsec
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.envs.env import EpisodeLengthSpec, check_reset_options, resolve_config
from planetnav_env.envs.spaces import (
    action_size,
    action_space,
    check_box_actions,
    check_target_actions,
    decode_observation,
    format_observation,
    observation_space,
)
from planetnav_env.errors import InvalidParameterError, require_count

_MODES = {"next_step": AutoresetMode.NEXT_STEP, "same_step": AutoresetMode.SAME_STEP}
#: ``info_keys`` choices: the documented key set, or its numeric, flat form (module docstring).
INFO_KEY_SETS = ("all", "numeric")
#: The info keys whose values are names (str or None); ``info_keys="numeric"`` leaves them out.
NAME_KEYS = ("target", "sensor", "visibility")
#: Gymnasium >= 1.1 has a mode without autoreset (TorchRL's preferred one); 1.0 does not.
_DISABLED = getattr(AutoresetMode, "DISABLED", None)
if _DISABLED is not None:
    _MODES["disabled"] = _DISABLED


def row_seeds(seed: int | Sequence[int | None] | None, num_rows: int) -> list[int | None]:
    """The seed of each row's generator for ``reset(seed=seed)``: an int ``s`` gives row ``n`` the seed
    ``s + n``, a list one seed (or None) per row, None fresh entropy for every row."""
    if seed is None:
        return [None] * num_rows
    if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
        return [int(seed) + n for n in range(num_rows)]
    seeds = list(seed)
    if len(seeds) != num_rows:
        raise InvalidParameterError(f"seed list must have {num_rows} entries, got {len(seeds)}")
    return seeds


class PlanetNavVectorEnv(EpisodeLengthSpec, VectorEnv):
    """``num_envs`` planetnav environments as one batch (see the module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}  # noqa: RUF012

    def __init__(
        self,
        num_envs: int = 1,
        config: EnvConfig | Mapping | str | None = None,
        autoreset_mode: str | AutoresetMode = "next_step",
        render_mode: str | None = None,
        info_keys: str = "all",
        **overrides: Any,
    ) -> None:
        require_count("num_envs", num_envs)
        if render_mode is not None:
            raise InvalidParameterError(
                f"the vector environment does not render (got render_mode={render_mode!r}); "
                "render a single PlanetNavEnv"
            )
        if not isinstance(info_keys, str) or info_keys not in INFO_KEY_SETS:
            raise InvalidParameterError(f"info_keys must be one of {list(INFO_KEY_SETS)}, got {info_keys!r}")
        self.info_keys = info_keys
        mode = (
            _MODES.get(autoreset_mode, autoreset_mode) if isinstance(autoreset_mode, str) else autoreset_mode
        )
        if mode not in _MODES.values():
            raise InvalidParameterError(
                f"autoreset_mode must be one of {list(_MODES)}, got {autoreset_mode!r}"
            )
        self.metadata = {**self.metadata, "autoreset_mode": mode}
        self.autoreset_mode = mode
        cfg = resolve_config(config, overrides)
        self.config = cfg
        self.num_envs = n = int(num_envs)
        self.core = BatchCore(cfg, n)
        self.layout = self.core.layout
        self.single_action_space = action_space(cfg)
        self.single_observation_space = observation_space(cfg, self.layout)
        self.action_space = batch_space(self.single_action_space, n)
        self.observation_space = batch_space(self.single_observation_space, n)
        self.render_mode = None
        self._generators: list[np.random.Generator] | None = None
        self._needs_reset = np.zeros(n, dtype=bool)
        self._raw = np.zeros((n, action_size(self.single_action_space)))  # target mode's raw actions
        self._rows = np.arange(n, dtype=np.int64)
        self._all_rows = np.ones(n, dtype=bool)
        self._all_rows.flags.writeable = False
        self._masks: dict[str, np.ndarray] | None = None  # the info's ``_key`` masks (built by _infos)
        # Name tables indexed by the core's codes; the appended None makes code -1 (no target) read None.
        self._target_names = np.array([*cfg.planets, *cfg.pulsars, None], dtype=object)
        self._sensor_names = np.array(L.SENSORS, dtype=object)
        self._reason_names = np.array(L.REASONS, dtype=object)

    # ------------------------------------------------------------------------------------------
    def reset(
        self, *, seed: int | list[int | None] | None = None, options: dict | None = None
    ) -> tuple[Any, dict[str, Any]]:
        """Reset every row (or the rows of ``options["reset_mask"]``, the only reset option). ``seed`` int s
        seeds row i with s + i; a list gives one seed (or None) per row."""
        check_reset_options(options, ("reset_mask",), "PlanetNavVectorEnv")
        n = self.num_envs
        seeds = row_seeds(seed, n)
        mask = np.ones(n, dtype=bool)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=bool)
            if mask.shape != (n,):
                raise InvalidParameterError(f"reset_mask must have shape ({n},), got {mask.shape}")
        if self._generators is None:
            self._generators = [seeding.np_random(s)[0] for s in seeds]
        else:
            for r in np.flatnonzero(mask):
                if seeds[r] is not None or self._generators[r] is None:
                    self._generators[r] = seeding.np_random(seeds[r])[0]
        rows = self._rows[mask]
        self.core.reset_rows(rows, [self._generators[r] for r in rows])
        self._needs_reset[mask] = False
        return self.observations(), self._infos()

    def _check(self, actions: Any) -> np.ndarray:
        """``actions`` checked (named errors, the whole batch before any row moves) into the raw (N, A)
        float64 actions the core decodes."""
        if self._generators is None:
            raise RuntimeError("call reset() before step()")
        cfg, n = self.config, self.num_envs
        if cfg.action_mode == "target":
            self._raw[:, 0] = check_target_actions(cfg, self.single_action_space.n, actions, n)
            return self._raw
        return check_box_actions(cfg, self.single_action_space.shape, actions, n)

    def step_rows(
        self, actions: Any, active: np.ndarray, on_step: Callable[[np.ndarray], None] | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Advance only the ``active`` rows (bool (N,)) by one step (one decision), with no autoreset: the
        building block
        of wrappers that run their own loop over steps (one policy decision held for several steps,
        ``planetnav_train.vec_training``). Returns ``(reward, terminated, truncated)``, zero / False for
        the rows
        not stepped. The caller resets finished rows (``reset(options={"reset_mask": ...})``, which
        continues each row's generator) before stepping them again; the whole ``actions`` batch is
        validated, inactive rows included. ``on_step(stepped)``: called after every physics step of the
        decision with the bool (N,) mask of the rows it advanced (``decision_steps`` > 1 holds each
        decision several physics steps; evaluation records each one through it)."""
        raw = self._check(actions)
        active = np.asarray(active, dtype=bool)
        if active.shape != (self.num_envs,):
            raise InvalidParameterError(f"active must have shape ({self.num_envs},), got {active.shape}")
        return self._advance(raw, active, on_step)

    def _advance(
        self,
        raw: np.ndarray,
        active: np.ndarray | None = None,
        on_step: Callable[[np.ndarray], None] | None = None,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Step the ``active`` rows (all when None) by one decision with checked raw actions (the core
        decodes them); (reward, terminated, truncated), zero / False for the rows not stepped."""
        core = self.core
        core.step_decision(raw, active, on_step)
        reward = core.f[:, L.F_REWARD].copy()
        terminated = core.i[:, L.I_TERMINATED] != 0
        truncated = core.i[:, L.I_TRUNCATED] != 0
        if active is not None:
            reward[~active] = 0.0
            terminated &= active
            truncated &= active
        return reward, terminated, truncated

    def step(self, actions: Any):
        cfg = self.config
        n = self.num_envs
        raw = self._check(actions)
        core = self.core
        if self.autoreset_mode == _DISABLED and self._needs_reset.any():
            raise RuntimeError(
                f"rows {np.flatnonzero(self._needs_reset).tolist()} have ended and autoreset_mode is "
                "'disabled': reset them (reset(options={'reset_mask': mask})) before step(); "
                "no row was stepped"
            )
        if self.autoreset_mode == AutoresetMode.NEXT_STEP and self._needs_reset.any():
            rows = np.flatnonzero(self._needs_reset)
            core.reset_rows(rows, [self._generators[r] for r in rows])
            reward, terminated, truncated = self._advance(raw, ~self._needs_reset)
        else:
            reward, terminated, truncated = self._advance(raw)
        done = terminated | truncated
        infos = self._infos()
        if self.autoreset_mode == AutoresetMode.SAME_STEP:
            if done.any():
                rows = np.flatnonzero(done)
                infos["final_obs"] = np.array([None] * n, dtype=object)
                infos["final_info"] = np.array([None] * n, dtype=object)
                obs_now = self.observations()
                for r in rows:
                    infos["final_obs"][r] = (
                        obs_now[r] if cfg.observation == "box" else {k: v[r] for k, v in obs_now.items()}
                    )
                    infos["final_info"][r] = self._final_info_row(int(r))
                infos["_final_obs"] = done.copy()
                infos["_final_info"] = done.copy()
                core.reset_rows(rows, [self._generators[r] for r in rows])
        else:
            self._needs_reset = done.copy()
        return self.observations(), reward, terminated, truncated, infos

    # ------------------------------------------------------------------------------------------
    def observations(self) -> Any:
        """Every row's current observation (a copy), as ``reset`` and ``step`` return them."""
        return format_observation(self.config, self.layout, self.core.obs)

    def _infos(self) -> dict[str, Any]:
        """The single environment's info keys as arrays over the rows (module docstring), each with its
        ``_key`` mask (all True: every row has every key); with ``info_keys="numeric"`` the numeric, flat
        form."""
        core = self.core
        # fc / ic: the state columns of this step, gathered into new arrays (batch.INFO_F / INFO_I);
        # the keys below are rows of them, so no value aliases the state the next step overwrites.
        info, fc, ic = core.info_batch_columns()
        numeric = self.info_keys == "numeric"
        if not numeric:
            info["target"] = self._target_names[ic[B.IC_TARGET]]
            info["sensor"] = self._sensor_names[ic[B.IC_SENSOR]]
            info["visibility"] = self._reason_names[ic[B.IC_REASON]]
        info["ambiguous_skipped"] = ic[B.IC_SKIPPED]
        info["attitude_err_arcsec"] = attitude_err_arcsec(fc[B.FC_ATT_ERR])
        x, p = core.filter_state()
        if numeric:
            info["filter_x"], info["filter_P"] = x, p
        else:
            info["filter"] = {"x": x, "P": p, "_x": self._all_rows, "_P": self._all_rows}
        masks = self._masks
        if masks is None or len(masks) != len(info):
            # Every key holds a value for every row: one read-only all-True mask, shared. The key set is
            # fixed by the config and info_keys, so the mask dict is built once (a loop of string
            # concatenations per step cost a few us, a visible part of a step at N = 1).
            masks = self._masks = {"_" + k: self._all_rows for k in info}
        info.update(masks)
        return info

    def _final_info_row(self, row: int) -> dict[str, Any]:
        """Row ``row``'s info for ``final_info``: the single environment's form, or with
        ``info_keys="numeric"`` its numeric, flat form (the names left out, the filter as ``filter_x``
        and ``filter_P``), the form of this env's ``info`` keys."""
        info = self.core.info_row(row)
        if self.info_keys == "all":
            return info
        flt = info.pop("filter")
        for k in NAME_KEYS:
            del info[k]
        info["filter_x"], info["filter_P"] = flt["x"], flt["P"]
        return info

    def filter_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Every row's filter estimate (N, 6) and covariance (N, 6, 6) (copies)."""
        return self.core.filter_state()

    def decode_observation(self, observation: Any) -> dict[str, Any]:
        """One row's observation in physical units (see :meth:`PlanetNavEnv.decode_observation`)."""
        return decode_observation(self.config, self.layout, observation)

    def info_row(self, row: int) -> dict[str, Any]:
        """Row ``row``'s info in the single environment's form (dicts, Python scalars)."""
        return self.core.info_row(int(row))

    def close_extras(self, **kwargs: Any) -> None:
        return None

    # -- Public accessors for wrappers and agents (``planetnav_agents``); the arrays are copies --
    @property
    def core_params(self) -> Any:
        """The compiled parameter record (``CoreParams``) the rows step with; read-only by convention.
        Agents' what-if kernels (greedy's score, the ``gain`` feature) take it so that their predictions
        use the environment's own measurement model and noise."""
        return self.core.params

    def current_targets(self) -> np.ndarray:
        """(N,) int64: each row's current target index (``config.planets`` order, then ``config.pulsars``),
        -1 for none; ``info["target_index"]``."""
        return self.core.i[:, L.I_TARGET].copy()

    def measured_flags(self) -> np.ndarray:
        """(N,) bool: whether each row's last step gave its filter an accepted measurement
        (``info["measured"]``)."""
        return self.core.i[:, L.I_MEASURED] != 0

    def info_arrays(self) -> dict[str, np.ndarray]:
        """Every row's info as arrays after the last reset / step (copies; ``pos_err_km`` [km],
        ``pos_sigma_km`` [km], ``measured``, ... as :meth:`BatchCore.info_batch`), no ``_key`` masks."""
        return self.core.info_batch()
