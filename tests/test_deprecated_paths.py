"""Moved public import paths (issue 20) still resolve, to the very object at the new path, and warn."""

from __future__ import annotations

import importlib

import pytest

#: (old module, name, new module)
MOVED = [
    *[
        ("planetnav_env.estimation.fast", name, "planetnav_env.estimation.ekf_kernels")
        for name in ("KIND_CODES", "SingleEKF", "cycle_batch_kernel", "predict_kernel", "update_kernel")
    ],
    ("planetnav_env.core.kernels", "CoreParams", "planetnav_env.core.records"),
    ("planetnav_env.core.kernels", "Scratch", "planetnav_env.core.records"),
    *[
        ("planetnav_env.core.kernels", name, "planetnav_env.estimation.measurement_kernels")
        for name in ("los_basis_kernel", "measurement_vector_kernel")
    ],
    ("planetnav_env.core.kernels", "pulsar_visibility_row", "planetnav_env.sensors.pulsar"),
    ("planetnav_env.core.kernels", "NOISE_PULSAR0", "planetnav_env.core.row_noise"),
    ("planetnav_env.core.kernels", "coasted_position_trace", "planetnav_env.core.what_if"),
    ("planetnav_env.core.kernels", "predicted_planet_trace", "planetnav_env.core.what_if"),
    ("planetnav_env.core.kernels", "predicted_pulsar_trace", "planetnav_env.core.what_if"),
    *[
        ("planetnav_env.sensors.camera", name, "planetnav_env.sensors.camera_kernels")
        for name in (
            "N_VIS_SLOTS",
            "V_ALPHA",
            "V_REASON",
            "V_PIX_X",
            "measure_into_kernel",
            "measure_row_kernel",
            "visibility_codes_kernel",
            "visibility_row_kernel",
        )
    ],
    ("planetnav_env.sensors.camera", "SUN_RADIUS_KM", "planetnav_env.sensors.camera_config"),
]


@pytest.mark.parametrize(("old", "name", "new"), MOVED)
def test_old_path_warns_and_returns_the_new_object(old: str, name: str, new: str) -> None:
    with pytest.warns(DeprecationWarning, match=rf"{old}\.{name} is deprecated: it moved to {new}\.{name}"):
        obj = getattr(importlib.import_module(old), name)
    assert obj is getattr(importlib.import_module(new), name)


def test_from_import_of_an_old_path_warns() -> None:
    with pytest.warns(DeprecationWarning, match="estimation.ekf_kernels"):
        from planetnav_env.estimation.fast import SingleEKF  # noqa: F401


def test_unknown_name_is_still_an_attribute_error() -> None:
    import planetnav_env.core.kernels as k
    import planetnav_env.estimation.fast as fast
    import planetnav_env.sensors.camera as camera

    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = k.nope
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = fast.nope
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        _ = camera.nope


def test_names_that_stayed_do_not_warn(recwarn: pytest.WarningsRecorder) -> None:
    # make_scratch and observe_row moved too, but the step still imports them: they stay plain names here.
    from planetnav_env.core.kernels import make_scratch, observe_row, step_batch, step_range  # noqa: F401

    assert not [w for w in recwarn if issubclass(w.category, DeprecationWarning)]


def test_camera_api_names_stay_plain(recwarn: pytest.WarningsRecorder) -> None:
    """Every public name of the camera API (its ``__all__``: the high-level functions and the re-exported
    config and geometry) imports from ``sensors.camera`` without a warning, as the object at its new home."""
    import planetnav_env.sensors.camera as camera
    import planetnav_env.sensors.camera_config as config
    import planetnav_env.sensors.camera_geometry as geometry

    for name in camera.__all__:
        obj = getattr(camera, name)
        for home in (config, geometry):
            if name in home.__all__:
                assert obj is getattr(home, name)
    assert not [w for w in recwarn if issubclass(w.category, DeprecationWarning)]
