"""Wahba solvers, the paper's conventions (eqs. (1), (3), (6), Euler angles), sign continuity, rates."""

import numpy as np
import pytest

from planetnav_env.attitude import quaternion as qt
from planetnav_env.attitude import wahba
from planetnav_env.errors import DegenerateGeometryError, InvalidParameterError, NonFiniteError
from planetnav_validation import body_rate, wahba_svd
from planetnav_validation.euler import (
    euler321_differences,
    euler321_error_angles,
    euler321_from_quaternion,
    quaternion_from_euler321,
)


def _unit(x):
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _random_q(rng, n):
    q = qt.normalize(rng.normal(size=(n, 4)))
    return q * np.where(q[:, :1] < 0, -1.0, 1.0)


def _paper_m(v, m32_as_printed=False):
    """The paper's eq. (1), element by element (orbital -> body)."""
    v0, v1, v2, v3 = v
    m = np.array(
        [
            [v0**2 + v1**2 - v2**2 - v3**2, 2 * (v1 * v2 + v0 * v3), 2 * (v1 * v3 - v0 * v2)],
            [2 * (v1 * v2 - v0 * v3), v0**2 - v1**2 + v2**2 - v3**2, 2 * (v0 * v1 + v2 * v3)],
            [2 * (v1 * v3 + v0 * v2), 2 * (v2 * v3 - v0 * v1), v0**2 - v1**2 - v2**2 + v3**2],
        ]
    )
    if m32_as_printed:
        m[2, 1] = 2 * (v2 * v3 - v0 * v2)
    return m


# --- conventions -------------------------------------------------------------------------------------


def test_paper_matrix_1_is_transpose_of_project_dcm():
    """The paper's v is the project's q of body relative to orbital: M(v) = R(v)^T (ERRATA item 1)."""
    rng = np.random.default_rng(0)
    for v in _random_q(rng, 20):
        np.testing.assert_allclose(_paper_m(v), qt.dcm_inertial_to_body(v), atol=1e-15)
        # The printed m32 is not a rotation matrix element: it breaks orthogonality.
        m = _paper_m(v, m32_as_printed=True)
        assert np.abs(m @ m.T - np.eye(3)).max() > 1e-3


def test_paper_euler_formula_is_z_y_x_product_and_inverts():
    rng = np.random.default_rng(1)
    psi, phi = rng.uniform(-np.pi, np.pi, size=(2, 200))
    theta = rng.uniform(-np.pi / 2 + 1e-3, np.pi / 2 - 1e-3, size=200)
    q = quaternion_from_euler321(psi, theta, phi)
    ez, ey, ex = np.eye(3)[2], np.eye(3)[1], np.eye(3)[0]
    prod = qt.multiply(
        qt.multiply(qt.from_axis_angle(ez, psi), qt.from_axis_angle(ey, theta)), qt.from_axis_angle(ex, phi)
    )
    np.testing.assert_allclose(q, prod, atol=1e-15)
    # Body x after yaw psi (pitch, roll 0) points at azimuth psi in the reference x-y plane.
    q_yaw = quaternion_from_euler321(0.3, 0.0, 0.0)
    np.testing.assert_allclose(
        qt.rotate_body_to_inertial(q_yaw, [1, 0, 0]), [np.cos(0.3), np.sin(0.3), 0], atol=1e-15
    )
    back = np.stack(euler321_from_quaternion(q), axis=-1)
    np.testing.assert_allclose(back, np.stack([psi, theta, phi], -1), atol=1e-9)
    np.testing.assert_allclose(np.stack(euler321_from_quaternion(-q), -1), back, atol=1e-12)


def test_error_angles_defined_at_gimbal_lock():
    q_true = quaternion_from_euler321(0.4, np.radians(89.9), -0.2)  # 0.1 deg from lock
    for i, axis in enumerate(np.eye(3)):  # 1 deg error about body x, y, z = roll, pitch, yaw
        q_est = qt.multiply(q_true, qt.from_axis_angle(axis, np.radians(1.0)))
        err = np.degrees(euler321_error_angles(q_true, q_est))
        np.testing.assert_allclose(err, np.eye(3)[2 - i], atol=1e-9)
    # Differences of the angles themselves blow up there: a 1 deg pitch error shows as ~170 deg in psi and
    # phi. This is why the reproduction reports both error definitions.
    q_est = qt.multiply(q_true, qt.from_axis_angle([0.0, 1.0, 0.0], np.radians(1.0)))
    assert np.degrees(euler321_differences(q_true, q_est))[0] > 90.0


# --- solvers ------------------------------------------------------------------------------------------


@pytest.mark.parametrize("n", [2, 3, 7])
def test_exact_recovery_noiseless(n):
    rng = np.random.default_rng(n)
    q = _random_q(rng, 500)
    r = _unit(rng.normal(size=(500, n, 3)))
    b = qt.rotate_inertial_to_body(q[:, None, :], r)  # r = R(q) b: the project convention
    w = rng.uniform(0.1, 10.0, size=(500, n))
    for solver in (wahba.q_method, wahba_svd.svd_method):
        est = solver(b, r, w)
        assert np.max(np.degrees(wahba.attitude_error_angle(est, q))) < 1e-9
        assert np.all(est[:, 0] >= 0.0)
        np.testing.assert_allclose(est, q, atol=1e-10)


def test_sign_convention_pinned_on_a_known_rotation():
    # Body rotated +90 deg about z relative to the reference: body x is reference y.
    b = np.array([[1.0, 0, 0], [0, 0, 1.0]])
    r = np.array([[0, 1.0, 0], [0, 0, 1.0]])
    q = wahba.q_method(b, r)
    np.testing.assert_allclose(q, [np.cos(np.pi / 4), 0, 0, np.sin(np.pi / 4)], atol=1e-15)


def test_paper_matrix_is_minus_davenport_k_scalar_last():
    rng = np.random.default_rng(3)
    b, r = _unit(rng.normal(size=(2, 50, 4, 3)))
    w = rng.uniform(0.5, 2.0, size=(50, 4))
    m = wahba.paper_matrix(b, r, w)
    k = wahba.davenport_k(b, r, w)
    perm = [1, 2, 3, 0]  # scalar-first -> scalar-last
    np.testing.assert_allclose(m, -k[:, perm][:, :, perm], atol=1e-13)
    # Optimal loss: J = 2 (sum a - lambda_max(K)) (criterion (2) with unit vectors).
    q = wahba.q_method(b, r, w)
    lam = np.linalg.eigvalsh(k)[:, -1]
    np.testing.assert_allclose(wahba_svd.wahba_loss(q, b, r, w), 2.0 * (w.sum(-1) - lam), atol=1e-12)


def test_solvers_agree_on_noisy_data_and_minimise_the_loss():
    rng = np.random.default_rng(4)
    q = _random_q(rng, 300)
    r = _unit(rng.normal(size=(300, 5, 3)))
    b = _unit(qt.rotate_inertial_to_body(q[:, None, :], r) + 0.05 * rng.normal(size=(300, 5, 3)))
    w = rng.uniform(0.2, 5.0, size=(300, 5))
    q1 = wahba.q_method(b, r, w)
    q2 = wahba_svd.svd_method(b, r, w)
    assert np.max(wahba.attitude_error_angle(q1, q2)) < 1e-9
    j = wahba_svd.wahba_loss(q1, b, r, w)
    for _ in range(5):
        dq = qt.from_axis_angle(rng.normal(size=(300, 3)), np.full(300, np.radians(0.5)))
        assert np.all(wahba_svd.wahba_loss(qt.multiply(q1, dq), b, r, w) >= j - 1e-12)


def test_noise_covariance_matches_inverse_sigma_squared_weighting():
    """QUEST model: with a_i = 1/sigma_i^2, cov(dtheta) = (sum (I - b b^T)/sigma_i^2)^-1 (body frame)."""
    rng = np.random.default_rng(5)
    n_mc = 40_000
    sig = np.radians(np.array([0.2, 0.5, 1.0, 2.0]))  # deliberately unequal
    r_ref = _unit(np.array([[1.0, 0.2, 0.1], [0.1, 1.0, -0.3], [-0.2, 0.3, 1.0], [0.7, -0.7, 0.2]]))
    q_true = _unit(np.array([0.9, 0.1, -0.3, 0.2]))
    b_true = qt.rotate_inertial_to_body(q_true, r_ref)
    noise = rng.normal(size=(n_mc, 4, 3)) * sig[:, None]
    noise -= np.sum(noise * b_true, -1, keepdims=True) * b_true  # tangent-plane noise
    b_meas = _unit(b_true + noise)

    def cov_of(weights):
        q_est = wahba.q_method(b_meas, r_ref, weights)
        dq = qt.multiply(qt.conjugate(q_true), q_est)
        dth = 2.0 * dq[:, 1:] * np.sign(dq[:, :1])
        return np.cov(dth.T)

    p_theory = np.linalg.inv(
        np.einsum("k,kij->ij", sig**-2, np.eye(3) - np.einsum("ki,kj->kij", b_true, b_true))
    )
    p_opt = cov_of(sig**-2)
    assert np.linalg.norm(p_opt - p_theory) / np.linalg.norm(p_theory) < 0.05
    # The printed eq. (6) weights by 1/a_i, i.e. by sigma^2 here: clearly worse (ERRATA item 3).
    p_inv = cov_of(sig**2)
    assert np.trace(p_inv) > 1.5 * np.trace(p_opt)


# --- degenerate and bad input ---------------------------------------------------------------------------


def test_degenerate_inputs_raise_clear_errors():
    e = np.array([[1.0, 0.0, 0.0]])
    with pytest.raises(DegenerateGeometryError, match="at least two"):
        wahba.q_method(e, e)
    par = np.array([[1.0, 0, 0], [2.0, 0, 0]])
    with pytest.raises(DegenerateGeometryError, match="parallel"):
        wahba.q_method(par, par)
    anti = np.array([[0, 0, 1.0], [0, 0, -1.0]])
    with pytest.raises(DegenerateGeometryError, match="parallel"):
        wahba_svd.svd_method(anti, anti)
    zero = np.array([[1.0, 0, 0], [0, 0, 0]])
    with pytest.raises(DegenerateGeometryError, match="zero-length"):
        wahba.q_method(zero, np.eye(3)[:2])
    good = np.eye(3)[:2]
    # One weight zero leaves a single vector.
    with pytest.raises(DegenerateGeometryError):
        wahba.q_method(good, good, [1.0, 0.0])
    with pytest.raises(InvalidParameterError):
        wahba.q_method(good, good, [1.0, -1.0])
    with pytest.raises(NonFiniteError):
        wahba.q_method(np.array([[np.nan, 0, 0], [0, 1.0, 0]]), good)
    with pytest.raises(InvalidParameterError):
        wahba.q_method(good, good, [1.0, 1.0, 1.0])
    # A degenerate member of a batch is named by its index.
    batch_b = np.stack([good, par])
    with pytest.raises(DegenerateGeometryError, match=r"\[\[1\]\]"):
        wahba.q_method(batch_b, batch_b)


# --- sign continuity and rates --------------------------------------------------------------------------


def _constant_rate_series(rng, t, omega):
    q0 = _random_q(rng, 1)[0]
    ang = np.linalg.norm(omega) * t
    dq = qt.from_axis_angle(np.broadcast_to(omega, (t.size, 3)), ang)
    return qt.multiply(q0, dq)  # body rate omega (right product): q_dot = 0.5 q * [0, omega]


def test_sign_continuity_rule():
    rng = np.random.default_rng(6)
    t = np.linspace(0.0, 20.0, 400)
    q = _constant_rate_series(rng, t, np.array([0.3, -0.2, 0.25]))  # several full turns: passes q0 = 0
    flips = np.where(rng.random(t.size) < 0.5, -1.0, 1.0)
    fixed = body_rate.enforce_sign_continuity(q * flips[:, None])
    assert fixed[0, 0] >= 0.0
    assert np.all(np.sum(fixed[1:] * fixed[:-1], axis=-1) > 0.0)
    np.testing.assert_allclose(np.abs(np.sum(fixed * q, axis=-1)), 1.0, atol=1e-12)  # same rotations
    # Batched over a leading axis.
    both = body_rate.enforce_sign_continuity(np.stack([q * flips[:, None], -q]))
    np.testing.assert_allclose(both[0], fixed)


def test_rate_from_quaternions_eq3_corrected():
    rng = np.random.default_rng(7)
    omega = np.array([0.02, -0.05, 0.03])  # rad/s
    dt = 0.5
    t = np.arange(200) * dt
    q = _constant_rate_series(rng, t, omega)
    flips = np.where(rng.random(t.size) < 0.5, -1.0, 1.0)  # estimates come with arbitrary signs
    w = body_rate.rate_from_quaternions(q * flips[:, None], dt)
    np.testing.assert_allclose(w, np.broadcast_to(omega, w.shape), atol=1e-5)  # O((omega dt)^2)
    # Exact derivative: eq. (3) recovers omega to rounding; the printed line 2 does not.
    q_dot = 0.5 * qt.multiply(q, np.concatenate([[0.0], omega]))
    w_exact = body_rate.body_rate_from_quaternion_rate(q, q_dot)
    np.testing.assert_allclose(w_exact, np.broadcast_to(omega, w_exact.shape), atol=1e-15)
    v0, v1, v2, v3 = q.T
    e0, e1, e2, e3 = q_dot.T
    w2_printed = 2 * (v0 * e2 - v3 * e0 + v1 * e3 - v2 * e1)
    assert np.max(np.abs(w2_printed - omega[1])) > 1e-3
    with pytest.raises(InvalidParameterError):
        body_rate.rate_from_quaternions(q[:1], dt)
    with pytest.raises(InvalidParameterError):
        body_rate.rate_from_quaternions(q, 0.0)


def test_vectorised_shepperd_matches_project_quaternion():
    rng = np.random.default_rng(8)
    q = _random_q(rng, 1000)
    np.testing.assert_allclose(wahba.quaternion_from_matrix(qt.dcm_body_to_inertial(q)), q, atol=1e-14)
    # 180 deg rotations (trace -1) take the other branches.
    for axis in np.eye(3):
        qq = qt.from_axis_angle(axis, np.pi)
        assert (
            wahba.attitude_error_angle(wahba.quaternion_from_matrix(qt.dcm_body_to_inertial(qq)), qq) < 1e-7
        )
