"""The records a row kernel receives: :class:`CoreParams` (shared, read-only parameters) and
:class:`Scratch` (work arrays of one chunk of rows, allocated once per call by :func:`make_scratch`)."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from planetnav_env.core import rng as crng
from planetnav_env.core.layout import TARGET_FEATURES
from planetnav_env.sensors.camera_kernels import (
    N_VIS_SLOTS,
)
from planetnav_env.sensors.star_tracker import FIX_WORK_SHAPE


class CoreParams(NamedTuple):
    """Everything a row kernel needs that is the same for every row, built once from an ``EnvConfig``
    by :func:`planetnav_env.core.params.build_params`. Scalars sit in ``s`` (float) and ``n`` (int) at
    the ``S_*``/``N_*`` slots of :mod:`planetnav_env.core.layout`."""

    s: np.ndarray  # (NS,) float64
    n: np.ndarray  # (NN,) int64
    jm: np.ndarray  # (3, 3) inertia [kg m^2]
    jinv: np.ndarray  # (3, 3)
    tau_max: np.ndarray  # (3,) wheel torque limits [N m]
    h_max: np.ndarray  # (3,) wheel momentum capacities [N m s]
    boresight: np.ndarray  # (3,) camera boresight, body axes
    radii: np.ndarray  # (P,) planet radii [km]
    mus: np.ndarray  # (K,) perturbers' GM [km^3/s^2]
    psr: np.ndarray  # (Q, 5) pulsar direction (3), wavelength [km], phase sigma [cycles]
    c2b: np.ndarray  # (3, 3) camera -> body
    cam: np.ndarray  # (11,) camera parameters (CameraConfig._params)
    qproc: np.ndarray  # (6, 6) process noise over one step
    stars: tuple  # star_tracker.StarFixTables
    q_bias: np.ndarray  # (4,) fixed star-tracker misalignment composed with every fix (identity: none)


class Scratch(NamedTuple):
    """Work arrays of one chunk of rows (allocated once per call, reused by every row)."""

    work: np.ndarray  # (8, 7) attitude RK4
    rq: np.ndarray  # (3, 3)
    a: np.ndarray  # (3, 3)
    frame: np.ndarray  # (3, 3)
    y: np.ndarray  # (7,)
    u_cmd: np.ndarray  # (3,)
    bias: np.ndarray  # (3,)
    zero3: np.ndarray  # (3,)
    w6: np.ndarray  # (3, 6, 6) orbit RK4
    v6: np.ndarray  # (4, 6)
    phi: np.ndarray  # (6, 6)
    tmp: np.ndarray  # (6, 6)
    x_new: np.ndarray  # (6,)
    uw: np.ndarray  # (5, 6, 6) EKF update
    h: np.ndarray  # (3,)
    jac: np.ndarray  # (3, 6)
    rcov: np.ndarray  # (3, 3)
    z: np.ndarray  # (3,)
    basis: np.ndarray  # (2, 3)
    m: np.ndarray  # (3, 3) camera
    u6: np.ndarray  # (6,)
    vals: np.ndarray  # (N_VIS_SLOTS,)
    los: np.ndarray  # (3,)
    los_true: np.ndarray  # (3,)
    mm: np.ndarray  # (2,)
    pix: np.ndarray  # (2,)
    r1: np.ndarray  # (1, 3) one-element batches for the camera kernels
    q1: np.ndarray  # (1, 4)
    t1: np.ndarray  # (1, 3)
    central: np.ndarray  # (3,) central body, heliocentric
    ssb: np.ndarray  # (3,) central body relative to the barycentre
    dirv: np.ndarray  # (3,)
    roll: np.ndarray  # (3,)
    pert: np.ndarray  # (3, K, 3) perturbers at t, t + dt/2, t + dt
    planets: np.ndarray  # (P, 3)
    r_tile: np.ndarray  # (P, 3)
    q_tile: np.ndarray  # (P, 4)
    feat: np.ndarray  # (P, TARGET_FEATURES)
    noise3: np.ndarray  # (3,)
    star_idx: np.ndarray  # (max_stars,) int64 catalogue indices in view
    star_noise: np.ndarray  # (max_stars, 3) per-star direction noise [rad]
    star_work: np.ndarray  # FIX_WORK_SHAPE
    q_fix: np.ndarray  # (4,)
    sub: np.ndarray  # (4,) uint64: a per-step noise stream (noise_streams "per_step")


@njit(cache=True)
def make_scratch(prm: CoreParams) -> Scratch:  # pragma: no cover - compiled
    n_p = prm.radii.shape[0]
    n_k = prm.mus.shape[0]
    n_s = prm.stars.max_stars
    # By keyword: a field is found by its name, not by its place among 44.
    return Scratch(
        work=np.empty((8, 7)),
        rq=np.empty((3, 3)),
        a=np.empty((3, 3)),
        frame=np.empty((3, 3)),
        y=np.empty(7),
        u_cmd=np.empty(3),
        bias=np.empty(3),
        zero3=np.zeros(3),
        w6=np.empty((3, 6, 6)),
        v6=np.empty((4, 6)),
        phi=np.empty((6, 6)),
        tmp=np.empty((6, 6)),
        x_new=np.empty(6),
        uw=np.empty((5, 6, 6)),
        h=np.empty(3),
        jac=np.empty((3, 6)),
        rcov=np.empty((3, 3)),
        z=np.empty(3),
        basis=np.zeros((2, 3)),
        m=np.empty((3, 3)),
        u6=np.empty(6),
        vals=np.empty(N_VIS_SLOTS),
        los=np.empty(3),
        los_true=np.empty(3),
        mm=np.empty(2),
        pix=np.empty(2),
        r1=np.empty((1, 3)),
        q1=np.empty((1, 4)),
        t1=np.empty((1, 3)),
        central=np.empty(3),
        ssb=np.empty(3),
        dirv=np.empty(3),
        roll=np.empty(3),
        pert=np.empty((3, n_k, 3)),
        planets=np.empty((n_p, 3)),
        r_tile=np.empty((n_p, 3)),
        q_tile=np.empty((n_p, 4)),
        feat=np.empty((n_p, TARGET_FEATURES)),
        noise3=np.empty(3),
        star_idx=np.empty(n_s, np.int64),
        star_noise=np.empty((n_s, 3)),
        star_work=np.empty(FIX_WORK_SHAPE),
        q_fix=np.empty(4),
        sub=np.empty(crng.STATE_WORDS, np.uint64),
    )
