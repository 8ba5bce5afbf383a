"""Sensor noise of one row: the sequential stream ``rng[n]`` or, with ``noise_streams="per_step"``, one
SplitMix64-derived stream per (step, sensor); the formulas live in :mod:`planetnav_env.core.rng`."""

from __future__ import annotations

from planetnav_env.core import rng as crng
from planetnav_env.core.layout import (
    I_K,
)  # fmt: skip
from planetnav_env.numerics.jit import row_kernel

#: Stream ids of the per-step noise (``noise_streams: per_step``): one per sensor; pulsar j uses
#: ``NOISE_PULSAR0 + j``; ``NOISE_THRUST`` is the thrust execution error of an operations scenario;
#: ``NOISE_IMAGE`` decides whether an image yields a fix (``EnvConfig.image_success_min``); ``NOISE_DRIFT``
#: drives the camera's boresight drift.
NOISE_STAR, NOISE_RATE, NOISE_CAMERA, NOISE_PULSAR0 = 1, 2, 3, 16
NOISE_THRUST = 4
NOISE_IMAGE = 5
#: The planet camera's boresight drift (``world.boresight_drift``): its stationary start at reset (step 0)
#: and its step after every physics step.
NOISE_DRIFT = 9
#: The thrust execution error's Gauss-Markov driving noise (``world.thrust_gauss_markov``): always a
#: stream of its own (:func:`own_stream_begin`), so that switching it on moves no other draw.
NOISE_THRUST_GM = 6
#: The flight world's attitude loop: the gyro's random walks over a step, a momentum dump's delta-v error.
NOISE_GYRO = 10
NOISE_DUMP = 11


@row_kernel
def noise_begin(prm, i, rng, n, stream, sc) -> None:  # pragma: no cover - compiled
    """Start drawing sensor ``stream``'s noise at the row's current step. With per-step streams this
    derives ``sc.sub`` from the row's key (``rng[n]``, then never advanced), the step index and the
    stream id; with the sequential stream it does nothing (draws continue ``rng[n]``)."""
    if prm.scalars[0].noise_per_step:
        crng.substream(rng[n], i[n, I_K], stream, sc.sub)


@row_kernel
def own_stream_begin(i, rng, n, stream, sc) -> None:  # pragma: no cover - compiled
    """Start a stream of its own for ``stream`` at the row's current step, whatever ``noise_streams``:
    ``sc.sub`` derived from the row's state ``rng[n]`` (read, not advanced), the step index and the
    stream id. Draw from it with :func:`next_own_normal`; no other stream's draws move."""
    crng.substream(rng[n], i[n, I_K], stream, sc.sub)


@row_kernel
def next_own_normal(sc) -> float:  # pragma: no cover - compiled
    """The next N(0, 1) of the stream begun by :func:`own_stream_begin`."""
    return crng.standard_normal(sc.sub)


@row_kernel
def next_normal(prm, rng, n, sc) -> float:  # pragma: no cover - compiled
    """The next N(0, 1) of the noise begun by :func:`noise_begin`."""
    if prm.scalars[0].noise_per_step:
        return crng.standard_normal(sc.sub)
    return crng.standard_normal(rng[n])


@row_kernel
def next_uniform(prm, rng, n, sc) -> float:  # pragma: no cover - compiled
    """The next uniform on [0, 1) of the noise begun by :func:`noise_begin`."""
    if prm.scalars[0].noise_per_step:
        return crng.uniform(sc.sub)
    return crng.uniform(rng[n])
