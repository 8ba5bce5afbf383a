"""X-ray pulsar sensor: catalogue vs independent positions, Sheikh TOA noise, phase model, ambiguity,
visibility."""

import numpy as np
import pytest

from planetnav_env.astro.bodies import AU_KM
from planetnav_env.astro.ephemeris import DEEphemeris, de421_path
from planetnav_env.astro.timescale import J2000_JD, tdb_seconds
from planetnav_env.errors import InvalidParameterError, NotVisibleError, PlanetNavError, UnknownBodyError
from planetnav_env.sensors import pulsar as psr

# ICRS -> galactic rotation (Hipparcos, ESA 1997, vol. 1, sec. 1.5.3): an independent frame to check the
# catalogue positions against the pulsars' published galactic coordinates.
_A_G = np.array(
    [
        [-0.0548755604162154, -0.8734370902348850, -0.4838350155487132],
        [+0.4941094278755837, -0.4448296299600112, +0.7469822444972189],
        [-0.8676661490190047, -0.1980763734312015, +0.4559837761750669],
    ]
)

# Galactic (l, b) [deg] as listed by the ATNF catalogue (Gl, Gb) and SIMBAD, to ~0.01 deg.
GALACTIC = {"B0531+21": (184.558, -5.784), "B1821-24": (7.798, -5.577), "B1937+21": (57.509, -0.290)}


def test_catalogue_has_the_required_pulsars_and_valid_fields():
    for name in ("B0531+21", "B1821-24", "B1937+21"):
        p = psr.pulsar(name)
        assert np.isclose(np.linalg.norm(p.direction), 1.0)
        assert 0.0 < p.pulsed_fraction <= 1.0
        assert 0.0 < p.duty_cycle < 0.2
        # Millisecond pulsars: lambda of a few hundred km; the Crab ~ 10,000 km.
        assert 300.0 < p.wavelength_km < 11_000.0


@pytest.mark.parametrize("name", sorted(GALACTIC))
def test_positions_match_published_galactic_coordinates(name):
    g = _A_G @ psr.pulsar(name).direction
    lon = np.degrees(np.arctan2(g[1], g[0])) % 360.0
    lat = np.degrees(np.arcsin(g[2]))
    assert lon == pytest.approx(GALACTIC[name][0], abs=0.01)
    assert lat == pytest.approx(GALACTIC[name][1], abs=0.01)


def test_names_are_looked_up_by_b_or_j_name_and_unknown_ones_raise():
    assert psr.pulsar("J0534+2200") is psr.pulsar("B0531+21")
    assert psr.pulsar("PSR B1821\u221224").bname == "B1821-24"  # typographic minus, PSR prefix
    assert psr.pulsar("crab").bname == "B0531+21"
    with pytest.raises(psr.UnknownPulsarError, match="B9999"):
        psr.pulsar("B9999+99")
    # The error is also an UnknownBodyError, a KeyError and a ValueError.
    for exc in (UnknownBodyError, KeyError, ValueError, PlanetNavError):
        with pytest.raises(exc):
            psr.pulsar("J0000+0000")


def test_toa_sigma_matches_an_independent_evaluation_of_sheikhs_formula():
    # Crab, 1 m^2, 1000 s, B = 0.005: counted by hand.
    a, t, b = 1e4, 1000.0, 0.005
    f, pf, w, per = 1.54e-2, 0.70, 1.7e-3, 0.0333924123
    pulsed = f * pf * a * t  # 107,800 photons in the pulse
    on_window_noise = (b + f * (1 - pf)) * a * t * (w / per)
    snr = pulsed / np.sqrt(on_window_noise + pulsed)
    assert psr.pulsar_toa_sigma_s("B0531+21") == pytest.approx(w / (2 * snr), rel=1e-12)
    assert psr.range_sigma_km("B0531+21") == pytest.approx(299_792.458 * w / (2 * snr), rel=1e-12)
    assert psr.phase_sigma_cycles("B0531+21") == pytest.approx(w / (2 * snr) / per, rel=1e-12)


def test_toa_sigma_limits():
    # Photon-limited, fully pulsed, no background: sigma = W / (2 sqrt(N)).
    s = psr.toa_sigma_s(1e-2, 1.0, 1e-3, 0.03, 0.0, 1e4, 100.0)
    assert s == pytest.approx(1e-3 / (2 * np.sqrt(1e-2 * 1e4 * 100.0)), rel=1e-12)
    # Source dominated: 1/sqrt(t); background dominated: 1/sqrt(t) too but with sqrt(B A t d) noise.
    s1, s4 = psr.toa_sigma_s(1e-2, 1.0, 1e-3, 0.03, 0.0, 1e4, [100.0, 400.0])
    assert s1 / s4 == pytest.approx(2.0, rel=1e-12)
    big_b = psr.toa_sigma_s(1e-6, 1.0, 1e-3, 0.03, 10.0, 1e4, [100.0, 400.0])
    assert big_b[0] / big_b[1] == pytest.approx(2.0, rel=1e-3)
    # Larger area, smaller error.
    assert psr.toa_sigma_s(1e-3, 0.5, 1e-3, 0.03, 0.005, 2e4, 500.0) < psr.toa_sigma_s(
        1e-3, 0.5, 1e-3, 0.03, 0.005, 1e4, 500.0
    )


@pytest.mark.parametrize(
    "kwargs",
    [
        {"area_cm2": 0.0},
        {"area_cm2": -1.0},
        {"integration_time_s": 0.0},
        {"integration_time_s": -5.0},
        {"area_cm2": float("nan")},
        {"integration_time_s": float("inf")},
        {"background_ph_cm2_s": -0.1},
        {"sun_avoidance_deg": 180.0},
        {"area_cm2": True},
    ],
)
def test_detector_rejects_bad_parameters(kwargs):
    with pytest.raises(InvalidParameterError):
        psr.XrayDetector(**kwargs)


@pytest.mark.parametrize("bad", [{"area_cm2": 0.0}, {"integration_time_s": -1.0}, {"pulsed_fraction": 1.5}])
def test_toa_sigma_rejects_bad_parameters(bad):
    args = {
        "flux_ph_cm2_s": 1e-3,
        "pulsed_fraction": 0.5,
        "pulse_width_s": 1e-3,
        "period_s": 0.03,
        "background_ph_cm2_s": 0.005,
        "area_cm2": 1e4,
        "integration_time_s": 500.0,
    } | bad
    with pytest.raises(InvalidParameterError):
        psr.toa_sigma_s(**args)


def test_sun_ssb_offset_agrees_with_the_kernels_mars_chain():
    t = tdb_seconds(2021, 2, 10) + np.array([0.0, 3600.0, 86400.0])
    from jplephem.spk import SPK  # the kernel read directly: an oracle independent of our wrapper

    kernel = SPK.open(de421_path())
    jd = J2000_JD + t / 86400.0
    mars_ssb = kernel[0, 4].compute(jd) + kernel[4, 499].compute(jd)
    ours = DEEphemeris().position("mars", t) + psr.sun_ssb_position(t)
    np.testing.assert_allclose(ours, mars_ssb.T, atol=1e-6)
    # The Sun's wobble about the barycentre: ~1 solar radius, never more than ~2e6 km.
    assert np.all(np.linalg.norm(psr.sun_ssb_position(t), axis=-1) < 2.2e6)


def test_phase_model_jacobian_and_measurement():
    rng = np.random.default_rng(5)
    r = rng.normal(size=(4, 3)) * AU_KM
    names = ("B0531+21", "B1937+21")
    jac = psr.phase_jacobian(4, names)
    h0 = psr.phase_model(r, names)
    for j in range(3):
        dr = np.zeros(3)
        dr[j] = 10.0
        fd = (psr.phase_model(r + dr, names) - psr.phase_model(r - dr, names)) / 20.0
        np.testing.assert_allclose(jac[:, :, j], fd, rtol=1e-6)
    assert np.all(jac[:, :, 3:] == 0.0)
    frac = psr.measure_phase(rng, r, names)
    assert np.all((frac >= 0.0) & (frac < 1.0))
    # Noise-free: the fraction is that of the model.
    frac0 = psr.measure_phase(None, r, names, noise=np.zeros((4, 2)))
    np.testing.assert_allclose(frac0, h0 - np.floor(h0), atol=1e-9)


def test_phase_noise_has_the_stated_sigma():
    rng = np.random.default_rng(11)
    r = np.tile(np.array([[1.2, -0.4, 0.3]]) * AU_KM, (20000, 1))
    det = psr.XrayDetector(area_cm2=100.0)
    frac = psr.measure_phase(rng, r, ["B0531+21"], det)
    total = psr.resolve_cycle_ambiguity(frac, psr.phase_model(r, ["B0531+21"]))
    resid = total - psr.phase_model(r, ["B0531+21"])
    sig = psr.phase_sigma_cycles("B0531+21", det)
    assert 1e-4 < sig < 1e-2
    assert np.std(resid) == pytest.approx(sig, rel=0.03)


def test_ambiguity_is_resolved_against_the_prediction():
    h_true = np.array([12345.3, 98.95, 7.02])
    frac = h_true - np.floor(h_true)
    # Prediction within half a cycle: the total phase comes back exactly.
    pred = h_true + np.array([0.45, -0.3, 0.2])
    np.testing.assert_allclose(psr.resolve_cycle_ambiguity(frac, pred), h_true, atol=1e-9)
    # Beyond half a cycle the rounding picks the wrong cycle (documented): off by one.
    wrong = psr.resolve_cycle_ambiguity(frac, h_true + 0.6)
    np.testing.assert_allclose(wrong - h_true, 1.0, atol=1e-9)
    # The rule used by the filter: 3 sigma < 1/2 cycle.
    assert psr.ambiguity_resolvable(0.1).item() and not psr.ambiguity_resolvable(0.2).item()


def test_sun_blocking_and_mars_occultation():
    n = psr.pulsar("B0531+21").direction
    # Spacecraft on the far side of the Sun from the pulsar: the Sun is exactly in the line of sight.
    r_blocked = -1.5 * AU_KM * n
    vis = psr.pulsar_visibility(r_blocked[None], ["B0531+21"])
    assert vis.sun_blocked[0, 0] and not vis.visible[0, 0]
    assert vis.sun_angle_rad[0, 0] == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(NotVisibleError, match="blocked by the Sun"):
        psr.check_visible(r_blocked, ["B0531+21"])
    # 20 deg off the Sun: blocked by the default 30 deg cone, visible with a 10 deg cone.
    rot = np.cross(n, [0.0, 0.0, 1.0])
    rot /= np.linalg.norm(rot)
    d = np.cos(np.radians(20)) * n + np.sin(np.radians(20)) * np.cross(rot, n)
    r20 = -1.5 * AU_KM * d
    assert not psr.pulsar_visibility(r20[None], ["B0531+21"]).visible[0, 0]
    assert psr.pulsar_visibility(r20[None], ["B0531+21"], psr.XrayDetector(sun_avoidance_deg=10.0)).visible[
        0, 0
    ]
    # Anti-Sun direction: visible.
    psr.check_visible(1.5 * AU_KM * n, ["B0531+21"])
    # Mars between the spacecraft and the pulsar: occulted; beside it: not.
    mars = np.array([2.0e8, 0.0, 0.0])
    sc_behind = mars - 20_000.0 * n
    with pytest.raises(NotVisibleError, match="occulted by Mars"):
        psr.check_visible(
            sc_behind, ["B0531+21"], occulter_pos_helio=mars, occulter_radius_km=3396.19, occulter_name="Mars"
        )
    side = np.cross(n, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    sc_beside = sc_behind + 5000.0 * side
    vis = psr.pulsar_visibility(
        np.stack([sc_behind, sc_beside]), ["B0531+21"], psr.XrayDetector(), mars, 3396.19
    )
    assert vis.occulted[:, 0].tolist() == [True, False]
    # Mars behind the spacecraft (pulsar side): not an occultation.
    assert not psr.pulsar_visibility(
        (mars + 20_000.0 * n)[None], ["B0531+21"], psr.XrayDetector(), mars, 3396.19
    ).occulted[0, 0]


# --- the flight world's timing terms (world.pulsar_shapiro, world.truth_ephemeris) -------------------------
GM_SUN_KM3_S2 = 1.32712440018e11  # IAU 2015 nominal (DE421's and DE440's value to 1e-10)
C_KM_S = 299_792.458


def _shapiro_finite_source_km(r_obs: np.ndarray, source: np.ndarray) -> float:
    """c times the Sun's Shapiro delay of a ray from ``source`` to ``r_obs`` (both heliocentric [km]):
    ``(2 GM / c^2) ln((|o| + |s| + |s - o|) / (|o| + |s| - |s - o|))`` (Shapiro 1964), an independent
    closed form: the kernel's is its limit for a source at infinity, referenced to the barycentre."""
    o, s = np.linalg.norm(r_obs), np.linalg.norm(source)
    d = np.linalg.norm(source - r_obs)
    s_minus_d = (2.0 * source @ r_obs - o * o) / (s + d)  # s - d without the cancellation of a far source
    return 2.0 * GM_SUN_KM3_S2 / C_KM_S**2 * np.log((o + s + d) / (o + s_minus_d))


def test_shapiro_range_against_the_finite_source_closed_form():
    rng = np.random.default_rng(5)
    dist = 1e15  # km: a source 30 pc away is at infinity to 1e-7 of the delay's variation here
    worst = 0.0
    sizes = []
    for _ in range(200):
        n = rng.normal(size=3)
        n /= np.linalg.norm(n)
        r = rng.normal(size=3)
        r *= rng.uniform(0.5, 1.7) * AU_KM / np.linalg.norm(r)
        b = rng.normal(size=3)
        b *= rng.uniform(1e5, 2e6) / np.linalg.norm(b)  # the barycentre: within ~3 solar radii
        got = psr.shapiro_range_km(r, b, n)
        # The phase referenced to the barycentre measures n.r_ssb minus c times the observer's delay
        # relative to the barycentre's (a later arrival reads as a smaller range).
        want = -(_shapiro_finite_source_km(r, dist * n) - _shapiro_finite_source_km(b, dist * n))
        worst = max(worst, abs(got - want))
        sizes.append(abs(got))
    assert worst < 1e-5  # km: 1 cm, the far source's finite distance
    assert psr.SHAPIRO_SCALE_KM == pytest.approx(2.953, rel=1e-3)
    # Its size at 0.5-1.7 AU: a few to ~20 km of range, comparable to a phase's range noise.
    assert 1.0 < np.median(sizes) < 25.0


def _pointing_at(boresight: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Scalar-first body -> inertial quaternion that turns ``boresight`` onto ``n`` (both unit)."""
    q = np.concatenate([[1.0 + boresight @ n], np.cross(boresight, n)])
    return q / np.linalg.norm(q)


def test_the_env_phase_in_truth_and_on_board_against_jplephem_and_the_closed_form():
    """One pulsar phase of the stepped core's own timing stage (``sensing.time_pulsar``), noise off: the
    truth's is ``n . r_ssb`` with the barycentre from DE440 (jplephem on de440.bsp) plus the Shapiro delay
    of the true position; the filter's prediction the same from DE421 and its estimate."""
    from jplephem.spk import SPK

    from planetnav_env.astro.ephemeris import de440_path
    from planetnav_env.batch import BatchCore
    from planetnav_env.config import EnvConfig
    from planetnav_env.core import layout as L
    from planetnav_env.core import sensing
    from planetnav_env.core.records import make_scratch
    from planetnav_env.core.row_ephemeris import eval_channel, truth_bodies_at

    cfg = EnvConfig(
        scenario="mars-approach", planets=["mars"], pulsars=["B0531+21"], world="flight",
        step_s=300.0, episode_steps=40,
    )  # fmt: skip
    core = BatchCore(cfg, 1)
    core.reset_rows(np.array([0]), [np.random.default_rng(2)])
    prm = core.params
    psr_rows = prm.psr.copy()
    psr_rows[:, 4] = 0.0  # no phase noise: the measured phase is the truth's model
    prm = prm._replace(psr=psr_rows)
    f, st = core.f, core.state
    nvec, lam = psr_rows[0, :3], psr_rows[0, 3]
    f[0, L.F_Q : L.F_Q + 4] = _pointing_at(np.asarray(prm.boresight), nvec)
    ps = prm.scalars[0]
    f[0, L.F_INTEGRATED] = ps["psr_int_s"]
    t = float(f[0, L.F_T0]) + 600.0
    sc = make_scratch(prm)
    eval_channel(prm, core.eph, f, 0, t, ps["ch_central"], sc.central)
    truth_bodies_at(prm, core.eph, f, 0, t, sc, False)
    measured, _, _ = sensing.time_pulsar(prm, st, 0, 0, t, sc)
    assert measured
    jd = J2000_JD + t / 86400.0
    jd0 = J2000_JD + float(f[0, L.F_T0]) / 86400.0
    x = f[0, L.F_X : L.F_X + 3].copy()
    new, old = SPK.open(de440_path()), SPK.open(de421_path())
    try:
        mars_new, sun_new = new[0, 4].compute(jd), new[0, 10].compute(jd)
        mars_old = old[0, 4].compute(jd) + old[4, 499].compute(jd)
        sun_old = old[0, 10].compute(jd)
        # The barycentres' constant difference at the episode's start, held in the timing model's phase.
        frame = new[0, 10].compute(jd0) - old[0, 10].compute(jd0)
    finally:
        new.close()
        old.close()
    assert 50.0 < np.linalg.norm(frame) < 200.0  # km: DE440's barycentre is ~116 km from DE421's
    mars_new, sun_new = mars_new - frame, sun_new - frame
    far = 1e15 * nvec

    def phase_km(r_rel_mars, mars_ssb, sun_ssb):
        r_helio = r_rel_mars + mars_ssb - sun_ssb
        shapiro = -(_shapiro_finite_source_km(r_helio, far) - _shapiro_finite_source_km(-sun_ssb, far))
        return nvec @ (r_rel_mars + mars_ssb) + shapiro, shapiro

    truth_km, shapiro_true = phase_km(x, mars_new, sun_new)
    # The filter's state was updated by the phase: its prediction h is sc.h[0], from the prior estimate.
    xe = sc.roll - sc.central  # the estimated heliocentric position the kernel used, relative to Mars
    model_km, _ = phase_km(xe, mars_old, sun_old)
    assert sc.z[0] * lam == pytest.approx(truth_km, abs=1e-3)
    assert sc.h[0] * lam == pytest.approx(model_km, abs=1e-3)
    assert 1.0 < abs(shapiro_true) < 30.0  # km: the delay is there, and of its stated size
    # What is left of the two barycentric Mars along the pulsar: the heliocentric difference (~0.5 km).
    assert 1e-3 < abs(nvec @ (mars_new - mars_old)) < 2.0
