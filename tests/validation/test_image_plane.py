"""Image-plane (p, l) model: against the camera module's kernel, Jacobian vs finite differences, bad input."""

import numpy as np
import pytest

from planetnav_env.attitude import quaternion as qt
from planetnav_env.errors import InvalidParameterError, NonFiniteError, NotVisibleError
from planetnav_env.sensors import camera
from planetnav_env.sensors.camera import CameraConfig
from planetnav_validation.image_plane import (
    boresight_attitude,
    boresight_camera_to_inertial,
    camera_to_inertial_matrix,
    image_plane_coordinates,
    image_plane_jacobian,
    image_plane_sigma_mm,
)

RNG = np.random.default_rng(3)


def _geometry(n, off_deg=2.0):
    """Spacecraft 1e4..1e6 km from a planet at the origin, camera pointed near the planet."""
    r = RNG.normal(size=(n, 3))
    r *= (10 ** RNG.uniform(4, 6, (n, 1))) / np.linalg.norm(r, axis=1, keepdims=True)
    los = -r / np.linalg.norm(r, axis=1, keepdims=True)
    q = boresight_attitude(los)
    # Tilt the attitude a little so that the planet is imaged off-centre.
    tilt = qt.from_axis_angle(RNG.normal(size=(n, 3)), np.radians(RNG.uniform(0, off_deg, n)))
    return r, qt.multiply(q, tilt)


def test_coordinates_match_the_camera_modules_kernel():
    r, q = _geometry(50)
    cfg = CameraConfig(direction_noise_arcsec=0.0, diameter_noise_px=0.0)
    r_ci = camera_to_inertial_matrix(q, cfg.camera_to_body_matrix)
    ours = image_plane_coordinates(r, np.zeros(3), r_ci, cfg)
    meas = camera.measure(
        np.random.default_rng(0), r, q, np.zeros((50, 3)), 3396.19, cfg, require_visible=False
    )
    np.testing.assert_allclose(ours, meas.image_mm, atol=1e-12)


def test_boresight_attitude_images_the_target_at_the_principal_point():
    r, _ = _geometry(10)
    los = -r / np.linalg.norm(r, axis=1, keepdims=True)
    pl = image_plane_coordinates(r, np.zeros(3), camera_to_inertial_matrix(boresight_attitude(los)))
    np.testing.assert_allclose(pl, 0.0, atol=1e-12)
    r_ci = boresight_camera_to_inertial(los)
    np.testing.assert_allclose(
        r_ci @ np.swapaxes(r_ci, 1, 2), np.broadcast_to(np.eye(3), (10, 3, 3)), atol=1e-12
    )
    np.testing.assert_allclose(np.linalg.det(r_ci), 1.0, atol=1e-12)
    # A line of sight along the default "up" (ICRF +Z) still gives a proper frame.
    assert np.isfinite(boresight_camera_to_inertial(np.array([[0.0, 0.0, 1.0]]))).all()


def test_a_known_offset_gives_f_tan_angle():
    # Planet 1 deg off the boresight along camera X: p = f tan(1 deg), l = 0.
    los = np.array([[1.0, 0.0, 0.0]])
    r_ci = boresight_camera_to_inertial(los)
    ex = r_ci[0, :, 0]
    d = np.cos(np.radians(1.0)) * los[0] + np.sin(np.radians(1.0)) * ex
    pl = image_plane_coordinates(-1e5 * d[None], np.zeros(3), r_ci)
    np.testing.assert_allclose(pl[0], [20.0 * np.tan(np.radians(1.0)), 0.0], atol=1e-12)


def test_jacobian_matches_central_differences():
    r, q = _geometry(30, off_deg=5.0)
    r_ci = camera_to_inertial_matrix(q)
    target = np.zeros(3)
    jac = image_plane_jacobian(r, target, r_ci)
    assert np.all(jac[:, :, 3:] == 0.0)
    for j in range(3):
        h = 1e-4 * np.linalg.norm(r, axis=1, keepdims=True)
        dr = np.zeros_like(r)
        dr[:, j] = h[:, 0]
        fd = (
            image_plane_coordinates(r + dr, target, r_ci) - image_plane_coordinates(r - dr, target, r_ci)
        ) / (2 * h)
        np.testing.assert_allclose(jac[:, :, j], fd, rtol=1e-6, atol=1e-12 * np.abs(fd).max())


def test_jacobian_with_a_nonzero_target_and_camera_mount():
    # A rotated camera mount and a target away from the origin: same check.
    c = qt.dcm_body_to_inertial(qt.from_axis_angle(np.array([1.0, 2.0, 3.0]), 0.7))
    target = np.array([1.0e6, -2.0e5, 3.0e4])
    r = target + np.array([[3.0e5, 1.0e5, -2.0e5]])
    los = (target - r) / np.linalg.norm(target - r)
    r_ci = boresight_camera_to_inertial(los)
    jac = image_plane_jacobian(r, target, r_ci)
    q = boresight_attitude(los, camera_to_body=c)
    np.testing.assert_allclose(camera_to_inertial_matrix(q, c), r_ci, atol=1e-12)
    for j in range(3):
        dr = np.zeros(3)
        dr[j] = 10.0
        fd = (
            image_plane_coordinates(r + dr, target, r_ci) - image_plane_coordinates(r - dr, target, r_ci)
        ) / 20.0
        np.testing.assert_allclose(jac[0, :, j], fd[0], rtol=1e-6, atol=1e-15)


def test_bad_input():
    r = np.array([[1e5, 0.0, 0.0]])
    r_ci = boresight_camera_to_inertial(np.array([[1.0, 0.0, 0.0]]))  # looks away from the origin
    with pytest.raises(NotVisibleError, match="behind the camera"):
        image_plane_coordinates(r, np.zeros(3), r_ci)
    with pytest.raises(NotVisibleError):
        image_plane_jacobian(r, np.zeros(3), r_ci)
    with pytest.raises(NonFiniteError):
        image_plane_coordinates(np.array([[np.nan, 0.0, 0.0]]), np.zeros(3), r_ci)
    with pytest.raises(InvalidParameterError):
        image_plane_coordinates(r, np.zeros(3), np.eye(2))
    with pytest.raises(InvalidParameterError):
        boresight_camera_to_inertial(np.zeros((1, 3)))
    with pytest.raises(InvalidParameterError):
        image_plane_sigma_mm(star_tracker_arcsec=-1.0)


def test_noise_sigma():
    cfg = CameraConfig(direction_noise_arcsec=4.0)
    assert image_plane_sigma_mm(cfg, 3.0) == pytest.approx(20.0 * np.radians(5.0 / 3600.0), rel=1e-12)
