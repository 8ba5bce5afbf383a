"""Star camera (planetnav_env/sensors/camera.py): projection, visibility rules, noise statistics, errors."""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest

from planetnav_env.astro.bodies import AU_KM, body
from planetnav_env.attitude import quaternion as qt
from planetnav_env.errors import InvalidParameterError, NonFiniteError, NotVisibleError
from planetnav_env.sensors import camera as cam
from planetnav_env.sensors.camera import CameraConfig, VisibilityReason

CFG = cam.DEFAULT_CAMERA
R_MARS = body("mars").radius
R_EARTH = body("earth").radius
R_MOON = body("moon").radius
Q_ID = np.array([1.0, 0.0, 0.0, 0.0])
# Spacecraft at 1 AU on +y: the Sun is along -y, 90 deg from the identity-attitude boresight
# (body x = inertial x).
R_SC = np.array([0.0, AU_KM, 0.0])


def pointing(d: np.ndarray, up: np.ndarray | None = None) -> np.ndarray:
    """Attitude whose body +x (the boresight) points along inertial ``d``."""
    d = np.asarray(d, float) / np.linalg.norm(d)
    up = np.array([0.0, 0.0, 1.0]) if up is None else np.asarray(up, float)
    if abs(d @ up) > 0.9:
        up = np.array([0.0, 1.0, 0.0])
    y = np.cross(up, d)
    y /= np.linalg.norm(y)
    return qt.from_dcm_body_to_inertial(np.column_stack([d, y, np.cross(d, y)]))


def target_at_pixel(px: float, py: float, dist: float, config: CameraConfig = CFG) -> np.ndarray:
    """Inertial target position that projects onto pixel (px, py) for R_SC at identity attitude."""
    v_cam = cam.pixel_to_camera([px, py], config)
    return R_SC + dist * cam.camera_to_body(v_cam, config)


# --- configuration ----------------------------------------------------------------------------------------


def test_defaults_and_derived_quantities():
    assert CFG.focal_length_mm == 20.0 and CFG.pixel_pitch_um == 5.5 and CFG.resolution_px == (1024, 1024)
    assert CFG.principal_point == (512.0, 512.0) and CFG.principal_point_px is None
    assert CFG.f_px == pytest.approx(20e-3 / 5.5e-6)
    assert CFG.ifov_rad / cam.ARCSEC_RAD == pytest.approx(56.72, abs=0.01)  # 56.7"/px
    assert CFG.half_fov_rad[0] == pytest.approx(math.atan(512 / CFG.f_px))
    assert math.degrees(CFG.half_fov_rad[0]) == pytest.approx(8.01, abs=0.01)
    assert math.degrees(CFG.half_fov_diagonal_rad) == pytest.approx(11.26, abs=0.01)
    # ERRATA 10: angular-diameter noise = diameter noise [px] / f_px, a constant.
    assert CFG.sigma_alpha_rad == pytest.approx(2.5 / CFG.f_px)
    assert CFG.sigma_direction_rad == pytest.approx(3.5 * math.pi / 648000)
    # Boresight is body +x; the default camera -> body matrix is a proper rotation.
    np.testing.assert_array_equal(CFG.boresight_body, [1.0, 0.0, 0.0])
    c = CFG.camera_to_body_matrix
    np.testing.assert_allclose(c @ c.T, np.eye(3), atol=0)
    assert np.linalg.det(c) == pytest.approx(1.0)
    assert hash(CFG) == hash(CameraConfig()) and CFG == CameraConfig()
    with pytest.raises(ValueError):
        CFG.camera_to_body_matrix[0, 0] = 5.0  # read-only view


def test_config_replace_and_pickle():
    c = dataclasses.replace(CFG, resolution_px=(2048, 1024))
    assert c.principal_point == (1024.0, 512.0)  # re-centred
    c2 = pickle.loads(pickle.dumps(c))
    assert c2 == c and c2.f_px == c.f_px
    v1 = cam.visibility(R_SC, Q_ID, R_SC + [3e7, 1e5, 0], None, None, R_MARS, c)
    v2 = cam.visibility(R_SC, Q_ID, R_SC + [3e7, 1e5, 0], None, None, R_MARS, c2)
    np.testing.assert_array_equal(v1.pixel, v2.pixel)


@pytest.mark.parametrize(
    ("field", "value"),
    [
        ("focal_length_mm", 0.0),
        ("focal_length_mm", -20.0),
        ("focal_length_mm", math.nan),
        ("pixel_pitch_um", 0.0),
        ("pixel_pitch_um", -1.0),
        ("resolution_px", (0, 1024)),
        ("resolution_px", (1024, -5)),
        ("resolution_px", (1024.5, 1024)),
        ("resolution_px", (1024,)),
        ("principal_point_px", (2000.0, 512.0)),
        ("direction_noise_arcsec", -0.1),
        ("diameter_noise_px", -1.0),
        ("min_diameter_px", -0.01),
        ("sun_exclusion_deg", -1.0),
        ("sun_exclusion_deg", 180.0),
        ("sun_exclusion_deg", math.inf),
        ("camera_to_body", np.diag([1.0, 1.0, -1.0]).tolist()),  # improper (a reflection)
        ("camera_to_body", [[1.0, 0.0], [0.0, 1.0]]),
        ("camera_to_body", (2 * np.eye(3)).tolist()),
        ("focal_length_mm", True),
    ],
)
def test_bad_config_names_the_field(field, value):
    with pytest.raises(InvalidParameterError, match=field):
        CameraConfig(**{field: value})


def test_config_accepts_yaml_like_lists_and_zero_noise():
    c = CameraConfig(
        resolution_px=[640, 480],
        principal_point_px=[320, 240],
        camera_to_body=np.eye(3).tolist(),
        direction_noise_arcsec=0,
        diameter_noise_px=0,
        sun_exclusion_deg=0,
        min_diameter_px=0,
    )
    assert c.resolution_px == (640, 480) and isinstance(c.camera_to_body, tuple)
    hash(c)


# --- geometry ---------------------------------------------------------------------------------------------


def test_apparent_diameter_exact_vs_thesis_model():
    x = np.array([1e-1, 1e-2, 1e-3])
    dist = R_MARS / x
    exact = cam.apparent_diameter(dist, R_MARS)
    model = cam.apparent_diameter_model(dist, R_MARS)
    np.testing.assert_allclose(exact, 2 * np.arcsin(x))
    np.testing.assert_allclose(model, 2 * np.arctan(x))
    # 2 asin x - 2 atan x = x^3 + O(x^5)
    np.testing.assert_allclose(exact - model, x**3, rtol=2e-2)
    with pytest.raises(InvalidParameterError):
        cam.apparent_diameter(R_MARS * 0.5, R_MARS)  # observer inside the body
    with pytest.raises(NonFiniteError):
        cam.apparent_diameter(np.nan, R_MARS)


def test_projection_round_trip():
    rng = np.random.default_rng(3)
    px = rng.uniform([-200, -200], [1224, 1224], size=(500, 2))
    v = cam.pixel_to_camera(px, CFG)
    np.testing.assert_allclose(np.linalg.norm(v, axis=-1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(cam.camera_to_pixel(v, CFG), px, rtol=0, atol=1e-9)
    mm = cam.camera_to_image_mm(v, CFG)
    np.testing.assert_allclose(mm, (px - 512.0) * 5.5e-3, atol=1e-12)  # mm = (px - c) * pitch
    # Any positive scaling of a camera vector projects to the same point.
    np.testing.assert_allclose(cam.camera_to_pixel(7.3e7 * v, CFG), px, atol=1e-9)
    # Body <-> camera round trip.
    vb = rng.normal(size=(20, 3))
    np.testing.assert_allclose(cam.camera_to_body(cam.body_to_camera(vb, CFG), CFG), vb, atol=1e-15)


def test_known_geometry_lands_on_expected_pixel():
    # Identity attitude: camera X = inertial +y, camera Y = inertial +z, boresight = inertial +x.
    L = 2.0e7
    t = R_SC + L * np.array([1.0, 100.0 / CFG.f_px, -50.0 / CFG.f_px])
    v = cam.visibility(R_SC, Q_ID, t, None, None, R_MARS, CFG)
    np.testing.assert_allclose(v.pixel, [612.0, 462.0], atol=1e-9)
    assert v.reason_at() is VisibilityReason.VISIBLE
    # Same through the numpy helpers (pins the kernel's rotation to quaternion.py).
    np.testing.assert_allclose(
        cam.camera_to_pixel(cam.inertial_to_camera(t - R_SC, Q_ID, CFG), CFG), v.pixel, atol=1e-9
    )
    # On the boresight: the principal point; image-plane mm relative to it.
    m = cam.measure(
        np.random.default_rng(0),
        R_SC,
        Q_ID,
        R_SC + [L, 0, 0],
        R_MARS,
        CameraConfig(direction_noise_arcsec=0.0, diameter_noise_px=0.0),
    )
    np.testing.assert_allclose(m.pixel, [512.0, 512.0], atol=1e-12)
    np.testing.assert_allclose(m.image_mm, [0.0, 0.0], atol=1e-15)
    np.testing.assert_allclose(m.los_body, [1.0, 0.0, 0.0], atol=1e-15)


def test_kernel_rotation_matches_quaternion_module():
    rng = np.random.default_rng(5)
    n = 200
    q = rng.normal(size=(n, 4)) * rng.uniform(0.5, 2.0, size=(n, 1))  # non-unit: normalised internally
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    r = np.tile(R_SC, (n, 1))
    t = r + 1e8 * d
    cfg = CameraConfig(camera_to_body=qt.dcm_body_to_inertial(qt.normalize(np.array([0.3, -0.2, 0.5, 0.1]))))
    v = cam.visibility(r, q, t, None, None, R_MARS, cfg)
    expected = cam.camera_to_pixel(cam.inertial_to_camera(d, q, cfg), cfg)
    np.testing.assert_allclose(v.pixel, expected, rtol=1e-10, atol=1e-9)
    m = cam.measure(
        np.random.default_rng(0),
        r,
        q,
        t,
        R_MARS,
        CameraConfig(camera_to_body=cfg.camera_to_body, direction_noise_arcsec=0, diameter_noise_px=0),
        require_visible=False,
    )
    np.testing.assert_allclose(m.los_body, qt.rotate_inertial_to_body(qt.normalize(q), d), atol=1e-14)
    # Boresight sun angle = angle between R(q) C e_z and -r.
    b = qt.rotate_body_to_inertial(qt.normalize(q), cfg.boresight_body)
    np.testing.assert_allclose(v.sun_angle_boresight_rad, cam.sun_angle(r, b), atol=1e-12)


# --- field of view ----------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("px", "py", "inside"),
    [
        # 1e-6 px either side of the edges (exactly on an edge is the closed rectangle, but round-off in the
        # pixel -> LOS -> pixel trip decides it there).
        (1e-6, 512.0, True),
        (1e-6, 1e-6, True),
        (-1e-6, 512.0, False),
        (1024.0 - 1e-6, 1024.0 - 1e-6, True),  # corner
        (1024.0 + 1e-6, 1024.0 - 1e-6, False),
        (512.0, 1024.0 + 1e-6, False),
        (1023.9, 0.1, True),
        (1100.0, 512.0, False),  # inside the circumscribed cone but off the rectangle ...
    ],
)
def test_fov_is_the_sensor_rectangle(px, py, inside):
    t = target_at_pixel(px, py, 3e7)
    v = cam.visibility(R_SC, Q_ID, t, None, None, R_MARS, CFG)
    assert bool(v.in_fov) is inside
    assert v.reason_at() is (VisibilityReason.VISIBLE if inside else VisibilityReason.OUT_OF_FOV)
    assert bool(cam.on_sensor(cam.pixel_to_camera([px, py], CFG), CFG)) is inside


def test_fov_rectangle_not_cone():
    # ... (1100, 512) is 9.2 deg off the boresight, less than the 11.3 deg half-diagonal: a cone would say in.
    off = math.atan(588 / CFG.f_px)
    assert off < CFG.half_fov_diagonal_rad
    assert not cam.on_sensor(cam.pixel_to_camera([1100.0, 512.0], CFG), CFG)


def test_behind_camera_is_out_of_fov_not_mirrored():
    t = R_SC - np.array([3e7, 0.0, 0.0])  # exactly behind the lens
    v = cam.visibility(R_SC, Q_ID, t, None, None, R_MARS, CFG)
    assert v.reason_at() is VisibilityReason.OUT_OF_FOV and np.all(np.isnan(v.pixel))
    assert not cam.on_sensor([0.0, 0.0, -1.0], CFG) and not cam.on_sensor([1.0, 0.0, 0.0], CFG)  # Z<0, Z=0
    assert np.all(np.isnan(cam.camera_to_pixel([0.1, 0.0, -1.0], CFG)))


def test_off_centre_principal_point():
    c = CameraConfig(principal_point_px=(100.0, 900.0))
    v = cam.visibility(R_SC, Q_ID, R_SC + [3e7, 0, 0], None, None, R_MARS, c)
    np.testing.assert_allclose(v.pixel, [100.0, 900.0], atol=1e-9)
    assert c.half_fov_rad[0] == pytest.approx(math.atan(924 / c.f_px))


# --- Sun exclusion, occultation, detection threshold -------------------------------------------------------


@pytest.mark.parametrize(
    ("angle_deg", "excluded"), [(29.0, True), (31.0, False), (90.0, False), (170.0, False)]
)
def test_sun_exclusion_of_the_boresight(angle_deg, excluded):
    # Spacecraft at (1 AU, 0, 0); Sun along -x. Boresight and target at angle_deg from the Sun direction.
    r = np.array([AU_KM, 0.0, 0.0])
    a = math.radians(angle_deg)
    d = np.array([-math.cos(a), math.sin(a), 0.0])
    v = cam.visibility(r, pointing(d), r + 5e7 * d, None, None, R_MARS, CFG)
    assert bool(v.sun_excluded) is excluded
    assert v.reason_at() is (VisibilityReason.SUN_EXCLUSION if excluded else VisibilityReason.VISIBLE)
    assert float(v.sun_angle_boresight_rad) == pytest.approx(a, abs=1e-12)
    # With the exclusion switched off the same geometry is visible.
    v0 = cam.visibility(r, pointing(d), r + 5e7 * d, None, None, R_MARS, CameraConfig(sun_exclusion_deg=0.0))
    assert v0.reason_at() is VisibilityReason.VISIBLE


def test_sun_exclusion_of_the_target_direction():
    # Boresight 35 deg from the Sun (outside the cone), target 7 deg towards the Sun from it (28 deg: inside).
    r = np.array([AU_KM, 0.0, 0.0])
    b = math.radians(35.0)
    a = math.radians(28.0)
    d_b = np.array([-math.cos(b), math.sin(b), 0.0])
    d_t = np.array([-math.cos(a), math.sin(a), 0.0])
    v = cam.visibility(r, pointing(d_b), r + 5e7 * d_t, None, None, R_MARS, CFG)
    assert bool(v.in_fov) and bool(v.sun_excluded)
    assert float(v.sun_angle_boresight_rad) > CFG.sun_exclusion_rad > float(v.sun_angle_target_rad)
    assert v.reason_at() is VisibilityReason.SUN_EXCLUSION
    np.testing.assert_allclose(cam.sun_angle(r, d_t), a, atol=1e-12)


def test_planet_behind_the_sun_is_occulted():
    # Earth-like spacecraft at +1 AU, Mars on the far side at -1.52 AU: the Sun's disk hides it.
    r = np.array([AU_KM, 0.0, 0.0])
    mars = np.array([-1.52 * AU_KM, 0.0, 0.0])
    v = cam.visibility(r, pointing(mars - r), mars, None, None, R_MARS, CFG)
    assert bool(v.in_fov) and bool(v.occulted) and bool(v.behind_sun)
    assert int(v.occulter) == cam.SUN_OCCULTER
    assert v.reason_at() is VisibilityReason.OCCULTED  # reported before SUN_EXCLUSION, which also holds
    assert bool(v.sun_excluded)
    # 1 deg off the Sun's centre: clear of the Sun's 0.27 deg disk but deep in the exclusion cone.
    d = np.array([-math.cos(0.0175), math.sin(0.0175), 0.0])
    t = r + np.linalg.norm(mars - r) * d
    v = cam.visibility(r, pointing(d), t, None, None, R_MARS, CFG)
    assert not bool(v.occulted) and v.reason_at() is VisibilityReason.SUN_EXCLUSION
    # include_sun=False: the Sun no longer occults.
    v = cam.visibility(r, pointing(mars - r), mars, None, None, R_MARS, CFG, include_sun=False)
    assert not bool(v.occulted) and v.reason_at() is VisibilityReason.SUN_EXCLUSION


def test_moon_in_front_of_earth():
    # Spacecraft 1e6 km from Earth along +x (boresight at Earth); the Moon 384400 km from Earth towards us.
    earth = np.array([0.0, AU_KM, 0.0])
    r = earth - np.array([1.0e6, 0.0, 0.0])
    q = pointing(earth - r)
    L_moon = 1.0e6 - 384_400.0
    rho_e = math.asin(R_EARTH / 1.0e6)
    rho_m = math.asin(R_MOON / L_moon)

    def vis(lateral_angle: float, moon_range: float = L_moon):
        moon = r + moon_range * np.array([math.cos(lateral_angle), 0.0, math.sin(lateral_angle)])
        others = np.array([moon, [5 * AU_KM, 0.0, 0.0]])  # a far body that never occults
        return cam.visibility(r, q, earth, others, [R_MOON, 1000.0], R_EARTH, CFG)

    v = vis(0.0)  # central
    assert v.reason_at() is VisibilityReason.OCCULTED and int(v.occulter) == 0
    v = vis(0.99 * (rho_e + rho_m))  # grazing: disks overlap (partial occultation counts)
    assert v.reason_at() is VisibilityReason.OCCULTED
    v = vis(1.01 * (rho_e + rho_m))  # disks just apart
    assert v.reason_at() is VisibilityReason.VISIBLE and int(v.occulter) == cam.NO_OCCULTER
    v = vis(0.0, 1.0e6 + 384_400.0)  # Moon behind the Earth: it is the Moon that is hidden, not Earth
    assert v.reason_at() is VisibilityReason.VISIBLE
    # The occulters may also be given per batch element: (..., M, 3).
    moon = r + L_moon * np.array([1.0, 0.0, 0.0])
    rr = np.stack([r, r])
    per = np.stack([[moon], [moon + [0.0, 0.0, 1e5]]])  # second: 1e5 km off the line
    v = cam.visibility(rr, np.stack([q, q]), np.stack([earth, earth]), per, [R_MOON], R_EARTH, CFG)
    np.testing.assert_array_equal(v.reason, [VisibilityReason.OCCULTED, VisibilityReason.VISIBLE])


def test_detection_threshold():
    c = CameraConfig(min_diameter_px=0.5)
    # Apparent diameter in px = alpha * f_px; 0.5 px <=> L = R / sin(alpha/2).
    alpha_min = 0.5 / c.f_px
    L_edge = R_MARS / math.sin(alpha_min / 2)
    for factor, small in ((0.99, False), (1.01, True)):
        v = cam.visibility(R_SC, Q_ID, R_SC + [factor * L_edge, 0, 0], None, None, R_MARS, c)
        assert bool(v.too_small) is small
        assert v.reason_at() is (VisibilityReason.TOO_SMALL if small else VisibilityReason.VISIBLE)
    # Default 0.02 px: Mars at 0.25 AU (~0.66 px) is sub-pixel but detected; at 10 AU it is not.
    for dist_au, small in ((0.25, False), (10.0, True)):
        v = cam.visibility(R_SC, Q_ID, R_SC + [dist_au * AU_KM, 0, 0], None, None, R_MARS, CFG)
        assert bool(v.too_small) is small
    v = cam.visibility(R_SC, Q_ID, R_SC + [0.25 * AU_KM, 0, 0], None, None, R_MARS, CFG)
    assert float(v.apparent_diameter_rad) * CFG.f_px == pytest.approx(0.66, abs=0.01)


def test_reason_precedence_batch():
    # Out of FOV wins over everything; batch shapes are kept.
    r = np.array([AU_KM, 0.0, 0.0])
    mars = np.array([-1.52 * AU_KM, 0.0, 0.0])
    q_away = pointing([0.0, 0.0, 1.0])
    v = cam.visibility(
        np.stack([r, r]).reshape(1, 2, 3),
        np.stack([pointing(mars - r), q_away]).reshape(1, 2, 4),
        mars,
        None,
        None,
        R_MARS,
        CFG,
    )
    assert v.reason.shape == (1, 2) and v.pixel.shape == (1, 2, 2)
    np.testing.assert_array_equal(v.reason, [[VisibilityReason.OCCULTED, VisibilityReason.OUT_OF_FOV]])
    assert not v.all_visible


# --- measurements -----------------------------------------------------------------------------------------


def _tangent_errors(los: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angular errors of ``los`` about ``truth`` along two perpendicular axes (independent basis)."""
    e1 = np.cross(truth, [0.0, 0.0, 1.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(truth, e1)
    return np.arctan2(los @ e1, los @ truth), np.arctan2(los @ e2, los @ truth)


def test_noise_statistics_and_unbiasedness():
    # n draws of a Gaussian: (n-1) s^2 / sigma^2 ~ chi2(n-1), so s/sigma = 1 +- 1/sqrt(2(n-1)) = 1 +- 0.35 %
    # at n = 40000. Tolerance 2 % (~6 sigma of that) for the std; means within 5 standard errors
    # sigma/sqrt(n).
    n = 40_000
    dist = 0.3 * AU_KM
    off = np.array([1.0, 200.0 / CFG.f_px, -300.0 / CFG.f_px])  # off-boresight truth, inside the FOV
    t = R_SC + dist * off / np.linalg.norm(off)
    m = cam.measure(np.random.default_rng(11), np.tile(R_SC, (n, 1)), Q_ID, t, R_MARS, CFG)
    truth = m.los_body_true[0]
    np.testing.assert_allclose(np.linalg.norm(m.los_body, axis=-1), 1.0, atol=1e-15)
    sigma = CFG.sigma_direction_rad
    for err in _tangent_errors(m.los_body, truth):
        assert abs(err.std(ddof=1) / sigma - 1.0) < 0.02
        assert abs(err.mean()) < 5 * sigma / math.sqrt(n)
    # Total angle: Rayleigh, E[theta^2] = 2 sigma^2.
    theta = np.arccos(np.clip(m.los_body @ truth, -1, 1))
    assert np.mean(theta**2) / (2 * sigma**2) == pytest.approx(1.0, abs=0.03)
    # Angular diameter: sigma_alpha = 2.5 px / f_px, unbiased about 2 asin(R/L).
    da = m.alpha_rad - m.alpha_true_rad
    np.testing.assert_allclose(m.alpha_true_rad, cam.apparent_diameter(dist, R_MARS), rtol=1e-12)
    assert abs(da.std(ddof=1) / CFG.sigma_alpha_rad - 1.0) < 0.02
    assert abs(da.mean()) < 5 * CFG.sigma_alpha_rad / math.sqrt(n)
    # Independence of the three draws (correlation ~ N(0, 1/n)).
    e1, e2 = _tangent_errors(m.los_body, truth)
    corr = np.corrcoef([e1, e2, da])
    assert np.all(np.abs(corr[np.triu_indices(3, 1)]) < 5 / math.sqrt(n))
    # At 0.3 AU Mars is ~0.2 sigma_alpha: negative alphas occur and are kept (unbiased measurement).
    assert np.any(m.alpha_rad < 0.0)
    # Image coordinates are those of the measured LOS.
    v_cam = cam.body_to_camera(m.los_body[:5], CFG)
    np.testing.assert_allclose(m.pixel[:5], cam.camera_to_pixel(v_cam, CFG), atol=1e-9)
    np.testing.assert_allclose(m.image_mm[:5], cam.camera_to_image_mm(v_cam, CFG), atol=1e-12)


def test_seeded_reproducibility_bit_for_bit():
    t = R_SC + [3e7, 1e5, -2e5]
    a = cam.measure(np.random.default_rng(42), R_SC, Q_ID, t, R_MARS, CFG)
    b = cam.measure(np.random.default_rng(42), R_SC, Q_ID, t, R_MARS, CFG)
    c = cam.measure(np.random.default_rng(43), R_SC, Q_ID, t, R_MARS, CFG)
    for name in ("los_body", "alpha_rad", "image_mm", "pixel"):
        assert np.array_equal(getattr(a, name), getattr(b, name))
        assert not np.array_equal(getattr(a, name), getattr(c, name))
    # One standard_normal((n, 3)) per call, also with zero noise: the stream does not depend on the sigmas.
    g1, g2 = np.random.default_rng(7), np.random.default_rng(7)
    cam.measure(g1, R_SC, Q_ID, t, R_MARS, CameraConfig(direction_noise_arcsec=0.0, diameter_noise_px=0.0))
    g2.standard_normal((1, 3))
    assert g1.standard_normal() == g2.standard_normal()
    # Batch element i of a batched call equals... its own draws in row i (documented order).
    z = np.random.default_rng(9).standard_normal((3, 3))
    m = cam.measure(np.random.default_rng(9), np.tile(R_SC, (3, 1)), Q_ID, t, R_MARS, CFG)
    np.testing.assert_allclose(m.alpha_rad - m.alpha_true_rad, CFG.sigma_alpha_rad * z[:, 2], rtol=1e-12)


def test_measuring_an_invisible_target_raises_and_draws_nothing():
    rng = np.random.default_rng(1)
    state = rng.bit_generator.state
    behind = R_SC - np.array([3e7, 0.0, 0.0])
    with pytest.raises(NotVisibleError, match=r"mars.*OUT_OF_FOV"):
        cam.measure(rng, R_SC, Q_ID, behind, R_MARS, CFG, target_name="mars")
    assert rng.bit_generator.state == state
    # Occulters are honoured by the check.
    t = R_SC + np.array([1e7, 0.0, 0.0])
    with pytest.raises(NotVisibleError, match="OCCULTED"):
        cam.measure(
            rng, R_SC, Q_ID, t, R_MARS, CFG, other_body_pos=[R_SC + [5e6, 0, 0]], other_body_radius=[R_MOON]
        )
    # Unchecked: measured anyway (the caller has checked visibility); image coordinates NaN behind the lens.
    m = cam.measure(rng, R_SC, Q_ID, behind, R_MARS, CFG, require_visible=False)
    assert m.visibility is None and np.all(np.isnan(m.pixel))
    np.testing.assert_allclose(m.los_body_true, [-1.0, 0.0, 0.0])


@pytest.mark.parametrize(
    "which",
    ["r_sc", "q_body_to_inertial", "target_pos", "target_radius", "other_body_pos", "other_body_radius"],
)
@pytest.mark.parametrize("bad", [math.nan, math.inf])
def test_non_finite_inputs_raise_naming_the_input(which, bad):
    args = {
        "r_sc": R_SC.copy(),
        "q_body_to_inertial": Q_ID.copy(),
        "target_pos": R_SC + [1e7, 0.0, 0.0],
        "target_radius": np.array(R_MARS),
        "other_body_pos": np.array([[0.0, 0.0, 5 * AU_KM]]),
        "other_body_radius": np.array([1000.0]),
    }
    args[which] = np.array(args[which], dtype=float)
    args[which].flat[0] = bad
    with pytest.raises(NonFiniteError, match=which):
        cam.visibility(
            args["r_sc"],
            args["q_body_to_inertial"],
            args["target_pos"],
            args["other_body_pos"],
            args["other_body_radius"],
            args["target_radius"],
            CFG,
        )
    if which.startswith("other"):
        return
    for require_visible in (True, False):
        with pytest.raises(NonFiniteError, match=which):
            cam.measure(
                np.random.default_rng(0),
                args["r_sc"],
                args["q_body_to_inertial"],
                args["target_pos"],
                args["target_radius"],
                CFG,
                require_visible=require_visible,
            )


def test_other_bad_inputs():
    t = R_SC + [1e7, 0.0, 0.0]
    with pytest.raises(InvalidParameterError, match="zero norm"):
        cam.visibility(R_SC, np.zeros(4), t, None, None, R_MARS, CFG)
    with pytest.raises(InvalidParameterError, match="target_radius"):
        cam.visibility(R_SC, Q_ID, t, None, None, -1.0, CFG)
    with pytest.raises(InvalidParameterError, match="inside the target"):
        cam.visibility(R_SC, Q_ID, R_SC + [100.0, 0, 0], None, None, R_MARS, CFG)
    with pytest.raises(InvalidParameterError, match="inside an occulting body"):
        cam.visibility(R_SC, Q_ID, t, [R_SC + [10.0, 0, 0]], [R_MOON], R_MARS, CFG)
    with pytest.raises(InvalidParameterError, match="inside an occulting body"):  # inside the Sun
        cam.visibility([1e5, 0.0, 0.0], Q_ID, [1e8, 0, 0], None, None, R_MARS, CFG)
    with pytest.raises(InvalidParameterError, match="other_body_radius"):
        cam.visibility(R_SC, Q_ID, t, [[0.0, 0.0, 5 * AU_KM]], [0.0], R_MARS, CFG)
    with pytest.raises(InvalidParameterError, match="shape"):
        cam.visibility(R_SC[:2], Q_ID, t, None, None, R_MARS, CFG)
    with pytest.raises(InvalidParameterError, match="together"):
        cam.visibility(R_SC, Q_ID, t, [[0.0, 0.0, 5 * AU_KM]], None, R_MARS, CFG)
    with pytest.raises(InvalidParameterError, match="Generator"):
        cam.measure(np.random.RandomState(0), R_SC, Q_ID, t, R_MARS, CFG)
    # An error inside a batch names the element.
    with pytest.raises(InvalidParameterError, match=r"batch index \(1,\)"):
        cam.visibility(np.stack([R_SC, R_SC]), np.stack([Q_ID, np.zeros(4)]), t, None, None, R_MARS, CFG)
