"""Potential-based reward shaping for training in torque modes (reported as shaping wherever used).

The environment's reward (navigation error, truth or covariance) is kept;
:class:`planetnav_train.batch_wrappers.PointingShapingRows` adds ``F = gamma * Phi(s') - Phi(s)`` (Ng,
Harada & Russell 1999), which leaves the optimal policies unchanged:
over an episode it sums to ``gamma^T Phi(s_T) - Phi(s_0)`` and only shifts the values. It is there
to make the first measurement discoverable: random wheel torques measure ~1 % of the steps, so the
navigation reward alone gives almost no gradient toward pointing the camera.

``Phi(s) = weight * max_p cos(angle between the boresight and planet p)`` over the planets observable if
pointed at, from the observation only (the per-planet estimated direction in body axes; the camera
boresight is body +x in every shipped configuration, and the wrapper checks it), 0 when none is
observable. ``weight`` is in reward units (the navigation reward is ``-error / reward_scale_km`` per
step, ~-0.1..-1.7 in cruise).

``pointing_bonus`` (config key ``shaping: {pointing_bonus: WEIGHT}``) is **not** potential-based: every
environment step (one decision: ``EnvConfig.decision_steps`` physics steps) it adds ``Phi(s')`` of the new
state (the same ``Phi`` with its own weight), a per-decision reward for pointing the boresight at an
observable planet. It changes the optimal policy (it pays for staring at one planet) and is reported as
shaping wherever used. It exists because the potential-based term cannot teach the pointing loop here:
its advantage signal vanishes as the critic learns ``-Phi``, and the navigation reward's own variance then
swamps the rest.

Used only in training (config key ``shaping: {pointing: WEIGHT}``), on arrays over the training env's
rows (:class:`planetnav_train.batch_wrappers.PointingShapingRows`; a single env is one row); evaluation
reports the unshaped navigation metrics.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L

#: Config keys of ``shaping:``: the potential-based term, the per-step pointing bonus (not potential-based).
SHAPINGS = ("pointing", "pointing_bonus")


def check_shaping(weight: float, gamma: float) -> tuple[float, float]:
    """(weight, gamma) of the pointing shaping, validated: ``ValueError`` naming a weight that is not
    > 0 or a gamma outside (0, 1]."""
    if not (np.isfinite(weight) and weight > 0):
        raise ValueError(f"shaping weight must be > 0, got {weight!r}")
    if not 0.0 < gamma <= 1.0:
        raise ValueError(f"shaping gamma must be in (0, 1], got {gamma!r}")
    return float(weight), float(gamma)


class PointingPotential:
    """``Phi`` of the module docstring for rows of box observations of configuration ``cfg``."""

    def __init__(self, cfg: EnvConfig, weight: float) -> None:
        if not np.allclose(cfg.camera.boresight_body, (1.0, 0.0, 0.0)):
            raise ValueError(
                f"pointing shaping assumes the camera boresight is body +x, got {cfg.camera.boresight_body}"
            )
        if cfg.observation != "box":
            raise ValueError(f"pointing shaping reads box observations, got observation={cfg.observation!r}")
        self.weight = check_shaping(weight, 1.0)[0]
        self._planets = L.ObservationLayout(cfg.n_planets, cfg.n_pulsars).planets_start
        self._n_planets = cfg.n_planets

    def __call__(self, observations: Any) -> np.ndarray:
        """(N,) float64 ``Phi`` [reward units] of observations (N, D)."""
        obs = np.asarray(observations, dtype=float)
        a = self._planets
        planets = obs[:, a : a + self._n_planets * L.TARGET_FEATURES].reshape(
            obs.shape[0], self._n_planets, L.TARGET_FEATURES
        )
        visible = planets[:, :, L.TF_OBSERVABLE] > 0.5
        # x component of the estimated body-frame direction = cos(angle off the boresight).
        cos = np.where(visible, planets[:, :, L.TF_DIR], -np.inf)
        return np.where(visible.any(axis=1), self.weight * np.max(cos, axis=1, initial=-np.inf), 0.0)
