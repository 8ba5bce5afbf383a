"""The flight world's camera truth through the env's own camera stage (``sensing.measure_planet`` on a row,
the camera's white noise set to zero so that each effect shows alone): the Lambertian centre-of-brightness
offset against a brute-force rendering of the lit sphere and its onboard correction, the oblate planet's
limb-fit size against a rendering of the spheroid's silhouette, and the boresight drift's variance and
autocorrelation from the env's rows against the Gauss-Markov process's definition."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from test_figure import rendered_outline
from test_photometry import rendered_cob

from planetnav_env.astro.bodies import AU_KM, body
from planetnav_env.attitude.quaternion import dcm_body_to_inertial
from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core import sensing
from planetnav_env.core.records import make_scratch
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.errors import OptionError
from planetnav_env.sensors.camera_kernels import rotate_in_camera

ARCSEC = math.pi / 648_000.0
#: The camera's white noise off (a diameter sigma of 0 would be the observation's zero size scale).
QUIET_CAMERA = {"direction_noise_arcsec": 0.0, "diameter_noise_px": 1e-12}


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    return math.atan2(float(np.linalg.norm(np.cross(a, b))), float(np.dot(a, b)))


def _core(world: dict, camera: dict | None = None, rows: int = 1, **kw) -> BatchCore:
    base = {**ENV_IDS["planetnav/Cruise-Target-v2"], "episode_steps": 8, "world": world}
    cfg = EnvConfig.from_dict({**base, "camera": camera if camera is not None else QUIET_CAMERA, **kw})
    core = BatchCore(cfg, rows)
    core.reset_rows(np.arange(rows), [np.random.default_rng(100 + r) for r in range(rows)])
    return core


def _image(core: BatchCore, idx: int, planet: np.ndarray, observer: np.ndarray):
    """The camera stage of row 0 on a hand-made geometry (heliocentric planet and observer [km], the row's
    attitude): returns the scratch after :func:`sensing.measure_planet` (``los``: the image's body-frame
    line of sight, ``los_true``: the planet's centre) and the row's true attitude."""
    prm, st = core.params, core.state
    sc = make_scratch(prm)
    sc.planets[idx] = planet  # truth and onboard alike: the geometry is the test's own
    sc.tplanets[idx] = planet
    sc.central[:] = 0.0
    sc.tcentral[:] = 0.0
    sc.r1[0] = observer
    sc.t1[0] = planet
    q = core.f[0, L.F_Q : L.F_Q + 4].copy()
    sc.q1[0] = q
    sensing.measure_planet(prm, st, 0, idx, sc)
    return sc, q


def _geometry(phase_deg: float, dist_km: float):
    """A planet at 1.5 AU and an observer ``dist_km`` from it at phase angle ``phase_deg``; returns
    (planet, observer, unit planet->Sun)."""
    planet = np.array([1.2, 0.9, 0.05]) * AU_KM
    sun = -planet / np.linalg.norm(planet)
    side = np.cross(sun, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    ph = math.radians(phase_deg)
    return planet, planet + dist_km * (math.cos(ph) * sun + math.sin(ph) * side), sun


@pytest.mark.parametrize("phase_deg", [20.0, 60.0, 85.0, 120.0, 160.0])
def test_centre_of_brightness_offset_matches_the_rendered_lambert_sphere(phase_deg):
    core = _core({"lambert_cob": True, "onboard_corrections": False})
    idx = core.config.planets.index("mars")
    dist = 2.0e6
    planet, observer, sun = _geometry(phase_deg, dist)
    sc, q = _image(core, idx, planet, observer)
    rho = math.asin(body("mars").radius / dist)  # the disk's apparent radius [rad]
    want = rendered_cob(math.radians(phase_deg)) * rho
    offset = _angle(sc.los, sc.los_true)
    assert offset == pytest.approx(want, rel=0.01)
    assert core.f[0, L.F_COB_LAST] == pytest.approx(offset, rel=1e-9)
    # Toward the Sun across the line of sight, in the image.
    sun_b = dcm_body_to_inertial(q).T @ sun
    across = sun_b - np.dot(sun_b, sc.los_true) * sc.los_true
    shift = sc.los - sc.los_true
    assert np.dot(shift, across) / (np.linalg.norm(shift) * np.linalg.norm(across)) > 1.0 - 1e-6


@pytest.mark.parametrize("scale", [1.0, 1.1, 0.9])
def test_the_onboard_photometric_model_removes_the_offset_up_to_its_scale_error(scale):
    """With the estimate at the truth, the onboard correction leaves (1 - scale) of the offset; the scale
    is the episode's draw, 1 + e with e uniform in [-cob_model_error, cob_model_error]."""
    core = _core({"lambert_cob": True})
    idx = core.config.planets.index("mars")
    planet, observer, _ = _geometry(90.0, 2.0e6)
    core.f[0, L.F_XE : L.F_XE + 3] = observer  # the estimate at the truth (heliocentric cruise)
    core.f[0, L.F_QE : L.F_QE + 4] = core.f[0, L.F_Q : L.F_Q + 4]
    core.f[0, L.F_COB_MODEL + idx] = scale
    sc, _ = _image(core, idx, planet, observer)
    offset = core.f[0, L.F_COB_LAST]
    assert offset > 0.0
    assert _angle(sc.los, sc.los_true) == pytest.approx(abs(1.0 - scale) * offset, rel=1e-6, abs=1e-15)


def test_the_onboard_correction_on_the_mars_approach_frame():
    """On the Mars approach (the state relative to Mars, the central body) the correction, from an
    estimate at the truth with the model's scale 1, removes the offset; the row's own reset geometry."""
    base = {**ENV_IDS["planetnav/MarsApproach-Tasking-v2"], "episode_steps": 8, "camera": QUIET_CAMERA}
    cfg = EnvConfig.from_dict({**base, "world": {"lambert_cob": True}})
    core = BatchCore(cfg, 1)
    core.reset_rows(np.array([0]), [np.random.default_rng(4)])
    f = core.f
    f[0, L.F_XE : L.F_XE + 6] = f[0, L.F_X : L.F_X + 6]
    f[0, L.F_QE : L.F_QE + 4] = f[0, L.F_Q : L.F_Q + 4]
    f[0, L.F_COB_MODEL] = 1.0
    mars = core.body_positions(0)["central"]
    prm, st = core.params, core.state
    sc = make_scratch(prm)
    sc.central[:] = mars
    sc.planets[0] = mars
    sc.tcentral[:] = mars  # truth and onboard alike: the geometry is the test's own
    sc.tplanets[0] = mars
    sc.r1[0] = f[0, L.F_X : L.F_X + 3] + mars
    sc.t1[0] = mars
    sc.q1[0] = f[0, L.F_Q : L.F_Q + 4]
    sensing.measure_planet(prm, st, 0, 0, sc)
    assert f[0, L.F_COB_LAST] > 100.0 * ARCSEC  # a resolved crescent: hundreds of arcsec
    assert _angle(sc.los, sc.los_true) < 1e-9 * f[0, L.F_COB_LAST]


def test_the_model_scale_is_drawn_per_planet_and_episode_in_its_bound():
    core = _core({"preset": "flight", "cob_model_error": 0.2}, rows=64)
    n_p = core.config.n_planets
    draws = core.f[:, L.F_COB_MODEL : L.F_COB_MODEL + n_p] - 1.0
    assert np.all(np.abs(draws) <= 0.2) and np.std(draws) == pytest.approx(0.2 / math.sqrt(3.0), rel=0.15)
    assert np.all(_core({"lambert_cob": True, "onboard_corrections": False}).f[0, L.F_COB_MODEL :][:n_p] == 0)


@pytest.mark.parametrize("lat_deg", [0.0, 30.0, 70.0])
def test_oblate_limb_fit_size_matches_the_rendered_spheroid(lat_deg):
    """The camera's measured angular diameter of Mars seen from sub-camera latitude ``lat_deg``: that of
    the circle of the rendered silhouette's area (orthographic, far from the planet)."""
    core = _core({"oblate_planets": True})
    idx = core.config.planets.index("mars")
    mars = body("mars")
    pole = mars.pole
    planet = np.array([1.2, 0.9, 0.05]) * AU_KM
    east = np.cross(pole, [1.0, 0.0, 0.0])
    east /= np.linalg.norm(east)
    lat = math.radians(lat_deg)
    dist = 5.0e6
    observer = planet + dist * (math.cos(lat) * east + math.sin(lat) * pole)
    prm, st = core.params, core.state
    sc = make_scratch(prm)
    sc.planets[idx], sc.central[:], sc.r1[0], sc.t1[0] = planet, 0.0, observer, planet
    sc.tplanets[idx], sc.tcentral[:] = planet, 0.0
    sc.q1[0] = core.f[0, L.F_Q : L.F_Q + 4]
    sensing.measure_planet(prm, st, 0, idx, sc)
    # The measured alpha is the filter's z; read it back through the measurement vector's source.
    radius = sensing._outline_radius(prm, sc, idx)
    _, _, area = rendered_outline(mars.radius, mars.polar_radius, lat)
    assert radius == pytest.approx(math.sqrt(area / math.pi), rel=5e-4)
    if lat_deg == 0.0:  # from the equator the outline is 0.3 % smaller than the onboard sphere
        assert 1.0 - radius / mars.radius == pytest.approx(0.00295, abs=2e-5)


def test_oblate_alpha_reaches_the_filter():
    """The filter's measured angular diameter is the spheroid's (camera noise off), not the sphere's."""
    core = _core({"oblate_planets": True})  # the default model, los+size, measures the diameter
    idx = core.config.planets.index("mars")
    planet, observer, _ = _geometry(40.0, 3.0e6)
    sc, _ = _image(core, idx, planet, observer)
    r = sensing._outline_radius(core.params, sc, idx)
    assert r < body("mars").radius
    assert sc.z[2] == pytest.approx(2.0 * math.asin(r / 3.0e6), rel=1e-12)


def test_rotate_in_camera_is_the_camera_frame_rotation():
    c2b = np.array(EnvConfig().camera.camera_to_body_matrix)
    rng = np.random.default_rng(3)
    for _ in range(20):
        v = rng.standard_normal(3)
        v /= np.linalg.norm(v)
        a = rng.normal(scale=1e-3, size=2)
        got = v.copy()
        rotate_in_camera(got, c2b, a[0], a[1])
        want = c2b @ Rotation.from_rotvec([a[0], a[1], 0.0]).apply(c2b.T @ v)
        assert np.allclose(got, want, atol=1e-15)


def test_boresight_drift_statistics_from_the_envs_rows():
    """The drift columns of 1,500 rows over 12 physics steps of 60 s with tau = 240 s: variance sigma^2 at
    every step (a stationary start) and autocorrelation exp(-lag dt / tau), both axes pooled."""
    sigma_as, tau = 3.0, 240.0
    rows, steps = 1500, 12
    world = {"boresight_drift": True, "drift_sigma_arcsec": sigma_as, "drift_tau_s": tau}
    core = _core(world, rows=rows, decision_steps=1)
    sigma = sigma_as * ARCSEC
    drift = [core.f[:, L.F_DRIFT : L.F_DRIFT + 2].copy()]
    actions = np.zeros((rows, 1))
    for _ in range(steps):
        core.step(actions)
        drift.append(core.f[:, L.F_DRIFT : L.F_DRIFT + 2].copy())
    x = np.stack(drift) / sigma  # (steps + 1, rows, 2), unit variance by definition
    m = 2 * rows
    for k in (0, 4, 12):
        assert np.var(x[k]) == pytest.approx(1.0, rel=5.0 * math.sqrt(2.0 / m))
    dt = core.config.step_s
    assert core.config.decision_steps == 1
    for lag in (1, 2, 4, 8):
        rho = float(np.mean(x[0] * x[lag]))
        assert rho == pytest.approx(math.exp(-lag * dt / tau), abs=5.0 / math.sqrt(m))


def test_the_drift_turns_the_planet_image_only():
    """Camera noise off, the drift alone: the image is the true line of sight turned by the row's drift
    about the camera's axes; the star fix is not (the drift is the planet camera's against the tracker)."""
    core = _core({"boresight_drift": True, "drift_sigma_arcsec": 30.0})
    idx = core.config.planets.index("mars")
    planet, observer, _ = _geometry(50.0, 2.0e6)
    ax, ay = core.f[0, L.F_DRIFT], core.f[0, L.F_DRIFT + 1]
    assert math.hypot(ax, ay) > 0.0
    sc, _ = _image(core, idx, planet, observer)
    want = sc.los_true.copy()
    rotate_in_camera(want, core.params.c2b, ax, ay)
    assert np.allclose(sc.los, want, atol=1e-15)
    matched = _core({})
    assert core.f[0, L.F_ATT_ERR] == matched.f[0, L.F_ATT_ERR]  # the same star fix


@pytest.mark.parametrize(
    "world,match",
    [
        ({"image_errors": 1}, "world.image_errors"),
        ({"centroid_floor_px": -0.1}, "world.centroid_floor_px"),
        ({"limb_scatter": float("nan")}, "world.limb_scatter"),
        ({"aperture_mm": 0.0}, "world.aperture_mm"),
        ({"psf_sigma_px": -1.0}, "world.psf_sigma_px"),
        ({"lambert_cob": "yes"}, "world.lambert_cob"),
        ({"cob_model_error": 1.5}, "world.cob_model_error"),
        ({"oblate_planets": 0.0}, "world.oblate_planets"),
        ({"drift_tau_s": 0.0}, "world.drift_tau_s"),
        ({"drift_tau_s": float("nan")}, "world.drift_tau_s"),
        ({"drift_sigma_arcsec": -3.0}, "world.drift_sigma_arcsec"),
    ],
)
def test_bad_camera_world_options_get_the_named_error_through_make(world, match):
    import gymnasium as gym

    import planetnav_env  # noqa: F401

    with pytest.raises((OptionError, TypeError), match=match):
        gym.make("planetnav/Cruise-Target-v2", world=world)
