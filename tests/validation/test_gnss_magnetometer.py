"""GNSS visibility, functional (5), dipole field, and the Belokonov & Kramlikh reproduction (short)."""

import json

import numpy as np
import pytest
from scipy.optimize import minimize

from planetnav_env.attitude import quaternion as qt
from planetnav_env.errors import DegenerateGeometryError, InvalidParameterError, NonFiniteError
from planetnav_validation import gnss_visibility as gv
from planetnav_validation.reproduce import gnss_magnetometer as gm


def _unit(x):
    return x / np.linalg.norm(x, axis=-1, keepdims=True)


def _fibonacci(m):
    i = np.arange(m) + 0.5
    z = 1.0 - 2.0 * i / m
    t = np.pi * (1.0 + 5**0.5) * i
    s = np.sqrt(1.0 - z * z)
    return np.stack([s * np.cos(t), s * np.sin(t), z], -1)


# --- geometry ---------------------------------------------------------------------------------------------


def test_constellation_geometry():
    rng = np.random.default_rng(0)
    pos = gv.constellation_positions(*rng.uniform(0, 2 * np.pi, size=(2, 3, 2)))
    assert pos.shape == (3, 48, 3)
    np.testing.assert_allclose(np.linalg.norm(pos[:, :24], axis=-1), gv.GPS.a_km)
    np.testing.assert_allclose(np.linalg.norm(pos[:, 24:], axis=-1), gv.GLONASS.a_km)
    # Inclination from the plane normals: the positions of two slots of one plane span the plane.
    for lo, inc in ((0, 55.0), (24, 64.8)):
        n = np.cross(pos[:, lo], pos[:, lo + 1])
        np.testing.assert_allclose(np.degrees(np.arccos(np.abs(_unit(n)[:, 2]))), inc, atol=1e-9)
    # GLONASS planes are 120 deg apart in RAAN: node vectors z x n.
    nodes = [_unit(np.cross([0, 0, 1.0], np.cross(pos[0, 24 + 8 * p], pos[0, 25 + 8 * p]))) for p in range(3)]
    ang = np.degrees(np.arccos(np.clip(np.dot(nodes[0], nodes[1]), -1, 1)))
    assert abs(ang - 120.0) < 1e-6 or abs(ang - 60.0) < 1e-6  # node vs. anti-node


def test_orbital_frame_axes():
    r, v = gv.circular_orbit(7000.0, np.radians(63.0), 0.3, np.linspace(0, 6, 7))
    c = gv.orbital_frame(r, v)
    np.testing.assert_allclose(c @ np.swapaxes(c, -1, -2), np.broadcast_to(np.eye(3), c.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(c), 1.0)
    np.testing.assert_allclose(c[:, 2], _unit(r), atol=1e-14)  # z2 radial
    np.testing.assert_allclose(c[:, 0], _unit(v), atol=1e-14)  # x2 along velocity on a circular orbit
    np.testing.assert_allclose(c[:, 1], _unit(np.cross(r, v)), atol=1e-14)


def test_earth_blocking_against_sampled_segments():
    rng = np.random.default_rng(1)
    r = _unit(rng.normal(size=(100, 3))) * (gv.R_EARTH_KM + 300.0)
    sats = _unit(rng.normal(size=(100, 10, 3))) * 26_000.0
    blocked = gv.earth_blocks(r, sats)
    t = np.linspace(0.0, 1.0, 2001)[:, None, None, None]
    pts = r[None, :, None, :] + t * (sats - r[:, None, :])[None]
    brute = np.min(np.linalg.norm(pts, axis=-1), axis=0) < gv.R_EARTH_KM
    assert np.mean(blocked == brute) > 0.995  # disagreements only at grazing incidence
    assert 0.2 < blocked.mean() < 0.6
    # Straight through the centre / straight up.
    assert gv.earth_blocks(
        np.array([7000.0, 0, 0]), np.array([[-26000.0, 0, 0], [26000.0, 0, 0]])
    ).tolist() == [
        True,
        False,
    ]


def test_dipole_field_directions():
    r_e = gv.R_EARTH_KM
    b_eq = gv.dipole_field(np.array([r_e, 0.0, 0.0]))
    np.testing.assert_allclose(b_eq, [0.0, 0.0, gv.DIPOLE_B0_NT], atol=1e-9)  # northward at the equator
    b_np = gv.dipole_field(np.array([0.0, 0.0, 2.0 * r_e]))
    np.testing.assert_allclose(b_np, [0.0, 0.0, -2.0 * gv.DIPOLE_B0_NT / 8.0], atol=1e-9)  # down at the pole
    # Divergence-free (finite differences) at a random point.
    x = np.array([5000.0, -3000.0, 4000.0])
    h = 1e-2
    div = sum(
        (gv.dipole_field(x + h * e)[i] - gv.dipole_field(x - h * e)[i]) / (2 * h)
        for i, e in enumerate(np.eye(3))
    )
    assert abs(div) < 1e-6


# --- functional (5) ---------------------------------------------------------------------------------------


def _random_problem(rng, n, k=20, p_excluded=0.3):
    g = _unit(rng.normal(size=(n, k, 3)))
    ant = _unit(rng.normal(size=(n, 3)))
    return g, ant, gv.classify_satellites(g, ant, rng.random((n, k)) < p_excluded)


def test_constrained_minimiser_is_the_global_minimum_on_the_sphere():
    rng = np.random.default_rng(2)
    g, _, cls = _random_problem(rng, 25)
    u = gv.antenna_constrained(g, cls)
    np.testing.assert_allclose(np.linalg.norm(u, axis=-1), 1.0, atol=1e-12)
    f = gv.antenna_functional(u, g, cls)
    grid = _fibonacci(20_000)
    for k in range(len(g)):
        vals = gv.antenna_functional(grid, g[k][None], cls[k][None])
        res = minimize(
            lambda x, k=k: gv.antenna_functional(_unit(x), g[k], cls[k]),
            grid[np.argmin(vals)],
            method="Nelder-Mead",
            options={"xatol": 1e-10, "fatol": 1e-13},
        )
        assert f[k] <= res.fun + 1e-10


def test_unconstrained_is_normalised_least_squares():
    rng = np.random.default_rng(3)
    g, _, cls = _random_problem(rng, 30)
    u = gv.antenna_unconstrained(g, cls)
    for k in range(len(g)):
        use = cls[k] != 0
        x, *_ = np.linalg.lstsq(g[k][use], cls[k][use].astype(float), rcond=None)
        np.testing.assert_allclose(u[k], _unit(x), atol=1e-12)


def test_both_estimates_converge_to_truth_with_dense_isotropic_satellites():
    """Independent truth: for isotropic lines of sight both minimisers are proportional to the antenna."""
    rng = np.random.default_rng(4)
    ant = _unit(rng.normal(size=(5, 3)))
    g = np.broadcast_to(_fibonacci(4000), (5, 4000, 3))
    cls = gv.classify_satellites(g, ant, np.zeros((5, 4000), bool))
    for fn in (gv.antenna_constrained, gv.antenna_unconstrained):
        err = np.degrees(np.arccos(np.clip(np.sum(fn(g, cls) * ant, -1), -1, 1)))
        assert np.all(err < 0.5)


def test_no_visible_and_all_visible_satellites_fall_back_to_the_one_sided_functional():
    """Documented fallback: with only one class present, (5) is still well posed and points the right way."""
    rng = np.random.default_rng(5)
    ant = np.array([0.0, 0.0, 1.0])
    g = _unit(rng.normal(size=(12, 3)))
    g_back = g * np.where(g @ ant < 0, 1.0, -1.0)[:, None]  # all behind the antenna: none visible
    for sats, expect in ((g_back, -1), (-g_back, 1)):  # none visible / all visible
        cls = gv.classify_satellites(sats, ant, np.zeros(12, bool))
        assert np.all(cls == expect)
        for fn in (gv.antenna_constrained, gv.antenna_unconstrained):
            u = fn(sats, cls)
            assert np.isfinite(u).all() and abs(np.linalg.norm(u) - 1) < 1e-12
            assert u @ ant > 0.0  # the correct hemisphere


def test_degenerate_and_bad_input():
    rng = np.random.default_rng(6)
    g, _, cls = _random_problem(rng, 4)
    with pytest.raises(DegenerateGeometryError, match="fewer than three"):
        gv.antenna_constrained(g, np.zeros_like(cls))  # every satellite Earth-shadowed
    two = np.zeros_like(cls)
    two[:, :2] = 1
    with pytest.raises(DegenerateGeometryError):
        gv.antenna_unconstrained(g, two)
    coplanar = g.copy()
    coplanar[..., 2] = 0.0
    with pytest.raises(DegenerateGeometryError):
        gv.antenna_constrained(_unit(coplanar), np.ones_like(cls))
    with pytest.raises(InvalidParameterError):
        gv.antenna_constrained(g, cls * 2)
    with pytest.raises(NonFiniteError):
        gv.antenna_unconstrained(np.where(g > 0.9, np.nan, g), cls)


@pytest.mark.parametrize("h", [0.0, -300.0, np.nan, np.inf, 20_000.0])
def test_non_physical_altitude_is_rejected(h):
    with pytest.raises(InvalidParameterError, match="altitude"):
        gv.validate_altitude(h)
    with pytest.raises(InvalidParameterError):
        gm.simulate(np.random.default_rng(0), 10, h)


# --- the reproduction ------------------------------------------------------------------------------------


def test_true_antenna_gives_exact_attitude_and_exact_field():
    """Pipeline plumbing: with the true antenna direction the q-method returns the true attitude."""
    sim = gm.simulate(np.random.default_rng(7), 500, 300.0)
    q = sim["q_true"]
    ant_true = qt.rotate_body_to_inertial(q, np.array([1.0, 0, 0]))
    q_est = gm._attitude_from_antenna(sim["b_body"], sim["b_orb"], ant_true, 10.0)
    assert np.degrees(qt.angle_between(q, q_est)).max() < 1e-5
    # With a huge magnetometer weight the estimate maps the measured field onto the model field.
    q_big = gm._attitude_from_antenna(sim["b_body"], sim["b_orb"], sim["antenna_constrained"], 1e8)
    b_pred = qt.rotate_inertial_to_body(q_big, sim["b_orb"])
    assert np.degrees(np.arccos(np.clip(np.sum(b_pred * sim["b_body"], -1), -1, 1))).max() < 0.05


def test_simulation_is_physically_sane():
    rng = np.random.default_rng(8)
    lo = gm.simulate(rng, 2000, 300.0)
    hi = gm.simulate(rng, 2000, 1000.0)
    for sim in (lo, hi):
        total = sim["n_visible"] + sim["n_structure"] + sim["n_shadowed"]
        assert np.all(total == 48)
        for key in ("antenna_err_constrained", "antenna_err_unconstrained", "total_err"):
            assert np.all((sim[key] >= 0) & (sim[key] <= 180))
            assert 1.0 < sim[key].mean() < 45.0
        assert np.all(sim["diff_err"] <= 180) and np.all(sim["rot_err"] <= 180)
    # Higher orbit: the Earth hides fewer satellites (the paper's explanation of its better accuracy).
    assert hi["n_shadowed"].mean() < lo["n_shadowed"].mean()
    # Antenna hemisphere is 180 deg: on average half the unshadowed satellites are visible.
    frac = lo["n_visible"].sum() / (lo["n_visible"] + lo["n_structure"]).sum()
    assert abs(frac - 0.5) < 0.02
    # Reproducible from the seed.
    again = gm.simulate(np.random.default_rng(8), 2000, 300.0)
    np.testing.assert_array_equal(again["q_est"], lo["q_est"])


def test_cli_writes_json_and_plots(tmp_path, capsys):
    out = tmp_path / "gm.json"
    plots = tmp_path / "plots"
    rc = gm.main(["--runs", "2000", "--sweep-runs", "300", "--json", str(out), "--plots", str(plots)])
    assert rc == 0
    data = json.loads(out.read_text())
    assert data["runs"] == 2000 and data["s"] == 10.0
    assert set(data["altitudes_km"]) == {"300", "1000"}
    for h in ("300", "1000"):
        a = data["altitudes_km"][h]
        assert set(a["antenna"]) >= {"constrained_mean_deg", "unconstrained_mean_deg"}
        assert set(a["angle_err_mean_deg"]) == {"psi", "theta", "phi"}
        for key in ("total_err_p90_deg", "visible_mean", "shadowed_mean"):
            assert np.isfinite(a[key])
        assert 0 < a["antenna"]["constrained_mean_deg"] < 45
        assert a["total_err_p90_deg"] >= a["total_err_mean_deg"] * 0.5
        assert 0 < a["visible_mean"] < 48 and 0 < a["shadowed_mean"] < 48
    assert data["altitudes_km"]["300"]["shadowed_mean"] > data["altitudes_km"]["1000"]["shadowed_mean"]
    assert len(data["s_sweep"]["300"]["s"]) == len(gm.S_SWEEP)
    assert len(sorted(plots.glob("fig*.png"))) == 10
    assert "antenna error" in capsys.readouterr().out


def test_cli_rejects_bad_arguments():
    with pytest.raises(SystemExit):
        gm.main(["--runs", "0"])
    with pytest.raises(SystemExit):
        gm.main(["--s", "-1"])
