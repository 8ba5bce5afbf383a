"""Pins the project's quaternion convention (see planetnav_env/attitude/quaternion.py)."""

import numpy as np

from planetnav_env.attitude import quaternion as qt


def test_rotation_about_z_is_active_body_to_inertial():
    # 90 deg about z: the body x axis points along inertial +y.
    q = qt.from_axis_angle([0.0, 0.0, 1.0], np.pi / 2)
    np.testing.assert_allclose(q, [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)])
    np.testing.assert_allclose(qt.rotate_body_to_inertial(q, [1.0, 0.0, 0.0]), [0.0, 1.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(qt.rotate_inertial_to_body(q, [0.0, 1.0, 0.0]), [1.0, 0.0, 0.0], atol=1e-15)


def test_dcm_matches_hamilton_sandwich():
    rng = np.random.default_rng(1)
    q = qt.normalize(rng.normal(size=(50, 4)))
    v = rng.normal(size=(50, 3))
    vq = np.concatenate([np.zeros((50, 1)), v], axis=1)
    sandwich = qt.multiply(qt.multiply(q, vq), qt.conjugate(q))[:, 1:]
    np.testing.assert_allclose(qt.rotate_body_to_inertial(q, v), sandwich, atol=1e-14)
    # Composition: R(p*q) = R(p) R(q).
    p = qt.normalize(rng.normal(size=(50, 4)))
    np.testing.assert_allclose(
        qt.dcm_body_to_inertial(qt.multiply(p, q)),
        qt.dcm_body_to_inertial(p) @ qt.dcm_body_to_inertial(q),
        atol=1e-14,
    )


def test_omega_matrix_is_right_product_with_body_rate():
    rng = np.random.default_rng(2)
    q = qt.normalize(rng.normal(size=(20, 4)))
    w = rng.normal(size=(20, 3))
    wq = np.concatenate([np.zeros((20, 1)), w], axis=1)
    np.testing.assert_allclose(
        np.einsum("...ij,...j->...i", qt.omega_matrix(w), q), qt.multiply(q, wq), atol=1e-14
    )


def test_dcm_roundtrip_and_sign():
    rng = np.random.default_rng(3)
    q = qt.normalize(rng.normal(size=(200, 4)))
    q *= np.sign(q[:, :1])
    back = qt.from_dcm_body_to_inertial(qt.dcm_body_to_inertial(q))
    np.testing.assert_allclose(back, q, atol=1e-12)


def test_angle_between():
    q = qt.from_axis_angle([1.0, 2.0, 3.0], 0.3)
    assert abs(qt.angle_between(q, -q)) < 1e-7
    assert abs(qt.angle_between(q, qt.from_axis_angle([1.0, 2.0, 3.0], 0.5)) - 0.2) < 1e-12
