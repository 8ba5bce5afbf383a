"""Integer codes shared by the compiled kernels and the Python side: one :class:`~enum.IntEnum` each.

Each set of codes is defined here once. The compiled kernels compare plain integers; the module-level
``int`` constants below are *derived* from the enums (``X = int(Enum.X)``) because numba folds an ``int``
global into a constant, which keeps the generated code (and every number) what it was with literals.

* :class:`VisibilityReason`: why a target can or cannot be measured this step (``info["visibility"]``);
  the camera's own rules come first (0-4), then the core's (5-8).
* :class:`MeasurementKind`: the filter's planet measurement model (``EnvConfig.measurement_model``).
* :class:`AttitudeStatus`, :class:`CameraStatus`, :class:`RowStatus`: status codes the batch kernels
  return, which the Python shells turn into named exceptions.
"""

from __future__ import annotations

from enum import IntEnum

__all__ = [
    "AttitudeStatus",
    "CameraStatus",
    "MeasurementKind",
    "RowStatus",
    "VisibilityReason",
]


class VisibilityReason(IntEnum):
    """Why a target can or cannot be measured; the first failing test in this order is reported.

    The camera's kernel reports 0-4; the simulation core adds 5-9 (``info["visibility"]`` is the
    lower-case name).
    """

    VISIBLE = 0
    OUT_OF_FOV = 1  # centre not on the sensor rectangle (or behind the camera)
    OCCULTED = 2  # another body's disk (the Sun included) in front of the target's disk
    SUN_EXCLUSION = 3  # boresight or target inside the Sun-exclusion cone
    TOO_SMALL = 4  # apparent diameter below the detection threshold (a brightness proxy)
    TOO_LARGE = 5  # the disk is wider than the sensor's field: neither centre nor diameter
    NONE = 6  # no target this step
    INTEGRATING = 7  # X-ray photons still accumulating on the pulsar
    AMBIGUOUS = 8  # the pulsar's whole number of cycles cannot be trusted: the phase is skipped
    IMAGE_FAILED = 9  # in view, but image processing yielded no fix (EnvConfig.image_success_min)

    @property
    def label(self) -> str:
        """The ``info["visibility"]`` string, e.g. ``"out_of_fov"``."""
        return self.name.lower()


class MeasurementKind(IntEnum):
    """Planet measurement model of the filter: (declination, right ascension) or the line of sight projected
    on the basis across the predicted line of sight, each optionally with the apparent diameter."""

    DIRECTION = 0
    DIRECTION_SIZE = 1
    LOS = 2
    LOS_SIZE = 3

    @property
    def label(self) -> str:
        """The configuration string, e.g. ``"direction+size"``."""
        return self.name.lower().replace("_size", "+size")

    @classmethod
    def from_label(cls, label: str) -> MeasurementKind:
        """The kind named ``label`` (``"direction"``, ``"direction+size"``, ``"los"``, ``"los+size"``)."""
        return _KIND_BY_LABEL[label]


_KIND_BY_LABEL = {k.label: k for k in MeasurementKind}


class AttitudeStatus(IntEnum):
    """Status of the attitude batch kernels (:mod:`planetnav_env.attitude.plant`,
    :mod:`planetnav_env.attitude.pointing`)."""

    OK = 0
    NONFINITE_INPUT = 1
    ZERO_Q = 2
    NONFINITE_RESULT = 3
    ZERO_DIRECTION = 4


class CameraStatus(IntEnum):
    """Status of the camera kernels (:mod:`planetnav_env.sensors.camera`)."""

    OK = 0
    NONFINITE = 1
    ZERO_Q = 2
    RADIUS = 3
    INSIDE_TARGET = 4
    INSIDE_OCC = 5
    OCC_RADIUS = 6


class RowStatus(IntEnum):
    """Status of one row of the simulation core after a step (``BatchState.i[:, I_STATUS]``)."""

    OK = 0
    ATTITUDE_NONFINITE = 1
    CAMERA = 2
