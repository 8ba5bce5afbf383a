"""Operations scenario A, ``planetnav/ThrustArc-TCM-v0`` (issue 17, research/operations_log.md §3): thrust
physics
against independent propagation, the discretised execution-error Q against numerical integration of its
PSD, filter consistency (NEES) under the thrust noise, the deadline bookkeeping against
``coasted_position_trace``, and the guarantees every id keeps (vector rows = single envs, pickle, checkers,
named config errors, per-step noise streams)."""

from __future__ import annotations

import copy
import math
import pickle

import gymnasium as gym
import numpy as np
import pytest
from scipy.stats import chi2

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig, OperationsSettings
from planetnav_env.core import layout as L
from planetnav_env.core.operations import add_thrust_q
from planetnav_env.core.what_if import coasted_position_trace
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import ConfigError
from planetnav_env.estimation.ekf_kernels import rk4_batch_kernel

ID = "planetnav/ThrustArc-TCM-v0"
OPS = dict(ENV_IDS[ID]["operations"])
DT = ENV_IDS[ID]["step_s"]
STAY = 3  # 3 planets, then "stay at the mission attitude"
OPS_INFO = ("dv_lost_m_s", "deadline_sigma_km", "deadline_err_km", "objective")


def _ops(**over) -> dict:
    return {**OPS, **over}


def _short(steps: int = 40, **ops_over) -> dict:
    """Options of a short ThrustArc episode: deadlines at steps 10 and 25, the encounter at ``steps``."""
    dl = ops_over.pop("deadlines_s", (10 * DT, 25 * DT))
    return {
        "episode_steps": steps,
        "operations": _ops(deadlines_s=dl, encounter_s=steps * DT, **ops_over),
    }


def _schedule(k: int) -> int:
    """Stay, with a 4-step session on a planet (cycling) every 10 steps."""
    return (k // 10) % 3 if k % 10 in (3, 4, 5, 6) else STAY


def _gravity_step(env, x: np.ndarray) -> np.ndarray:
    """The truth's gravity-only RK4 step (two-body heliocentric in random-cruise: no perturbers)."""
    prm = env.unwrapped.core.params
    empty = np.zeros((0, 3))
    out = x[None, :].copy()
    rk4_batch_kernel(out, DT, float(prm.scalars[0]["mu"]), empty, empty, empty, prm.mus)  # in place
    return out[0]


# ------------------------------------------------------------------------------------------------
# Configuration
# ------------------------------------------------------------------------------------------------
def test_default_is_no_operations_and_the_section_round_trips() -> None:
    assert EnvConfig().operations is None
    cfg = EnvConfig.from_dict(ENV_IDS[ID])
    assert isinstance(cfg.operations, OperationsSettings)
    assert cfg.operations.deadlines_s == (604800.0, 1382400.0, 1684800.0)
    assert EnvConfig.from_dict(cfg.to_dict()) == cfg
    a = cfg.operations.thrust_accel_km_s2
    assert a == pytest.approx(0.092 / 486.0 / 1000.0, rel=1e-15)
    q_par, q_perp = cfg.operations.psd_km2_s3  # research/operations_log.md §3.1: 2.48e-12 and 1.89e-12
    assert q_par == pytest.approx(2 * (0.02 * a) ** 2 * 86400, rel=1e-12)
    assert q_par == pytest.approx(2.48e-12, rel=0.01)
    assert q_perp == pytest.approx(1.89e-12, rel=0.01)


@pytest.mark.parametrize(
    "key,value",
    [
        ("thrust_n", 0.0), ("thrust_n", -1.0), ("mass_kg", float("nan")), ("thrust_mag_sigma", -0.1),
        ("thrust_point_sigma_deg", float("inf")), ("thrust_corr_time_s", 0.0),
        ("attitude_tolerance_deg", 0.0), ("attitude_tolerance_deg", 95.0), ("deadlines_s", []),
        ("deadlines_s", [5.0, 3.0]),
        ("deadlines_s", [1.0, 2e9]), ("deadlines_s", ["a"]), ("deadlines_s", list(range(1, 11))),
        ("encounter_s", -5.0), ("cost_weight", -1.0), ("cost_weight", True), ("bogus", 1.0),
    ],
)  # fmt: skip
def test_each_bad_operations_key_or_value_raises_naming_it(key: str, value) -> None:
    with pytest.raises(ConfigError, match=key):
        EnvConfig.from_dict(ENV_IDS[ID], operations=_ops(**{key: value}))


def test_operations_need_the_stay_action_target_mode_and_no_pulsars() -> None:
    with pytest.raises(ConfigError, match="idle_action"):
        EnvConfig.from_dict({**ENV_IDS[ID], "idle_action": False})
    with pytest.raises(ConfigError, match="action_mode"):
        EnvConfig.from_dict({**ENV_IDS[ID], "action_mode": "torque", "idle_action": False})
    with pytest.raises(ConfigError, match="operations"):
        EnvConfig(operations={"thrust_n": 1.0})  # a mapping only through from_dict


# ------------------------------------------------------------------------------------------------
# Physics
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("frac", [1.0, 0.37])
def test_discretised_q_matches_numerical_integration_of_the_psd(frac: float) -> None:
    """Q = f * int_0^dt Phi(dt - s) G A G^T Phi(dt - s)^T ds (free flight, G = [0; I]) with
    A = q_perp I + (q_par - q_perp) u u^T, integrated by Simpson's rule: the white noise of PSD f q."""
    q_par, q_perp = 2.48e-12, 1.89e-12
    u = np.array([0.3, -0.5, 0.8])
    u /= np.linalg.norm(u)
    a = q_perp * np.eye(3) + (q_par - q_perp) * np.outer(u, u)
    s = np.linspace(0.0, DT, 2001)
    integrand = np.empty((s.size, 6, 6))
    for k, sk in enumerate(s):
        g = np.vstack([(DT - sk) * np.eye(3), np.eye(3)])  # Phi(dt - s) G
        integrand[k] = g @ a @ g.T
    w = np.ones(s.size)
    w[1:-1:2], w[2:-1:2] = 4.0, 2.0
    q_num = frac * np.tensordot(w, integrand, axes=1) * (s[1] - s[0]) / 3.0
    p = np.zeros((6, 6))
    add_thrust_q(p, DT, frac, q_par, q_perp, u)
    np.testing.assert_allclose(p, q_num, rtol=1e-10, atol=1e-12 * np.abs(q_num).max())
    assert np.all(np.linalg.eigvalsh(p) > 0)


def _run_recording(env, actions):
    """Step ``env`` (reset) with ``actions``, recording (truth x before, info after) per step."""
    rec = []
    for a in actions:
        x0 = env.unwrapped.truth["x"]
        xe0 = env.unwrapped.core.f[0, L.F_XE : L.F_XE + 6].copy()
        _, _, _, _, info = env.step(a)
        rec.append((x0, xe0, info, env.unwrapped.truth["x"]))
    return rec


def test_dv_lost_is_the_thrust_acceleration_times_the_time_off_attitude() -> None:
    """Without execution error, the truth's velocity gains a t_on u over the gravity-only step; the
    delta-v lost is a (dt - t_on): their sum is a dt every step, slews included. A step held on a planet
    far from the thrust direction loses a dt exactly, and a settled stay step loses nothing."""
    env = gym.make(ID, **_short(40, thrust_mag_sigma=0.0, thrust_point_sigma_deg=0.0))
    env.reset(seed=3)
    acc = env.unwrapped.config.operations.thrust_accel_km_s2
    acts = [STAY] * 6 + [0] * 3 + [STAY] * 3 + [2] * 3 + [STAY] * 3
    rec = _run_recording(env, acts)
    total = 0.0
    for k, (x0, xe0, info, x1) in enumerate(rec):
        dv_thrust = np.linalg.norm(x1[3:] - _gravity_step(env, x0)[3:])  # [km/s]
        dv_lost = info["dv_lost_m_s"] - total
        total = info["dv_lost_m_s"]
        assert dv_thrust * 1e3 + dv_lost == pytest.approx(acc * DT * 1e3, rel=1e-6), k
        u = xe0[3:] / np.linalg.norm(xe0[3:])
        if dv_thrust > 0:  # along the planned direction
            kick = (x1[3:] - _gravity_step(env, x0)[3:]) / dv_thrust
            assert np.dot(kick, u) == pytest.approx(1.0, abs=1e-9)
    lost = np.diff([0.0] + [r[2]["dv_lost_m_s"] for r in rec])
    assert lost[5] == 0.0  # settled at the mission attitude
    assert lost[7] == pytest.approx(acc * DT * 1e3, rel=1e-12)  # held on a planet all step
    assert 0.0 < lost[9] < acc * DT * 1e3  # slewing back: thrust for part of the step


def test_no_thrust_noise_while_imaging() -> None:
    """With the execution error on, a step held on a planet (engine off) is the gravity step exactly, and
    the filter's covariance grows by the cruise Q only."""
    env = gym.make(ID, **_short(40, thrust_mag_sigma=0.5, thrust_point_sigma_deg=20.0))
    env.reset(seed=5)
    rec = _run_recording(env, [STAY] * 4 + [1] * 4)
    for x0, _, info, x1 in rec[5:]:
        assert info["measured"] or info["visibility"] != "visible"
        np.testing.assert_array_equal(x1, _gravity_step(env, x0))


def test_deadline_sigma_is_the_coasted_trace_of_the_filter_covariance() -> None:
    env = gym.make(ID, **_short(30))
    _, info = env.reset(seed=2)
    assert (info["deadline_sigma_km"] == 0.0).all() and info["objective"] == 0.0
    w = env.unwrapped.config.operations.cost_weight
    scale = env.unwrapped.config.reward_scale_km
    total = 0.0
    for k in range(1, 31):
        _, r, _, _, info = env.step(_schedule(k))
        total += r
        sig, err = info["deadline_sigma_km"], info["deadline_err_km"]
        for d, kd in enumerate((10, 25)):
            if k < kd:
                assert sig[d] == 0.0 and err[d] == 0.0  # not reached yet
            elif k == kd:
                t_go = (30 - kd) * DT
                p = info["filter"]["P"]
                assert sig[d] == math.sqrt(coasted_position_trace(p, t_go))
                e = info["filter"]["x"] - env.unwrapped.truth["x"]
                assert err[d] == pytest.approx(np.linalg.norm(e[:3] + t_go * e[3:]), rel=1e-12)
                assert sig[d] > 0 and err[d] > 0
    # J = sum of the deadline sigmas (reward: covariance) + w * dv lost; the rewards sum to -J / scale.
    assert info["objective"] == pytest.approx(sig.sum() + w * info["dv_lost_m_s"], rel=1e-12)
    assert total == pytest.approx(-info["objective"] / scale, rel=1e-12)


def test_truth_reward_uses_the_true_mapped_error() -> None:
    env = gym.make(ID, reward="truth", **_short(30))
    env.reset(seed=2)
    for k in range(1, 31):
        _, _, _, _, info = env.step(_schedule(k))
    w = env.unwrapped.config.operations.cost_weight
    want = info["deadline_err_km"].sum() + w * info["dv_lost_m_s"]
    assert info["objective"] == pytest.approx(want, rel=1e-12)


def _nees_runs(n_runs: int, steps: int, seed: int) -> np.ndarray:
    """(steps, n_runs) NEES of the 6-state filter with a strong thrust noise (0.3 of a along, 10 deg
    across, tau = 1 d: ~200x the registered PSD, so the thrust Q dominates the filter's growth), staying
    at the thrust attitude with a 4-step session every 10 steps."""
    venv = PlanetNavVectorEnv(n_runs, ID, **_short(steps, thrust_mag_sigma=0.3, thrust_point_sigma_deg=10.0))
    venv.reset(seed=seed)
    out = np.empty((steps, n_runs))
    for k in range(steps):
        _, _, _, _, info = venv.step(np.full(n_runs, _schedule(k)))
        out[k] = info["nees"]
    return out


def _assert_nees_consistent(nees: np.ndarray) -> None:
    n_runs = nees.shape[1]
    lo, hi = chi2.ppf([0.025, 0.975], 6 * n_runs) / n_runs
    anees = nees.mean(axis=1)
    inside = (anees >= lo) & (anees <= hi)
    assert inside.mean() >= 0.9, f"ANEES inside [{lo:.2f}, {hi:.2f}] at {inside.mean():.0%} of steps"
    # and over the whole run, every step pooled (a looser check that a bias would still fail)
    assert 0.8 * 6 <= anees.mean() <= 1.2 * 6


def test_nees_is_chi_square_under_the_thrust_noise() -> None:
    _assert_nees_consistent(_nees_runs(60, 60, seed=100))


@pytest.mark.slow
def test_nees_is_chi_square_under_the_thrust_noise_long() -> None:
    _assert_nees_consistent(_nees_runs(200, 300, seed=200))


# ------------------------------------------------------------------------------------------------
# Guarantees every id keeps
# ------------------------------------------------------------------------------------------------
def _same(a, b) -> bool:
    if isinstance(b, dict):
        return all(np.array_equal(a[k], b[k]) for k in b)
    if b is None or isinstance(b, str):
        return a == b
    return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True))


@pytest.mark.parametrize("noise_streams", ["sequential", "per_step"])
def test_vector_rows_equal_single_envs_every_info_key(noise_streams: str) -> None:
    """Row i of the vector env equals the single env seeded seed + i: observation, reward, flags and every
    info key (the operations keys included), through a whole episode with both deadlines."""
    n, seed, steps = 3, 11, 30
    opts = {**_short(steps), "noise_streams": noise_streams}
    venv = PlanetNavVectorEnv(n, ID, **opts)
    singles = [PlanetNavEnv(ID, **opts) for _ in range(n)]
    vobs, _ = venv.reset(seed=seed)
    for i, env in enumerate(singles):
        np.testing.assert_array_equal(vobs[i], env.reset(seed=seed + i)[0])
    rng = np.random.default_rng(0)
    for _ in range(steps):
        acts = np.where(rng.random(n) < 0.7, STAY, rng.integers(0, 3, n))
        vobs, vr, vterm, vtrunc, vinfo = venv.step(acts)
        for i, env in enumerate(singles):
            obs, r, term, trunc, info = env.step(int(acts[i]))
            assert np.array_equal(vobs[i], obs) and vr[i] == r and (vterm[i], vtrunc[i]) == (term, trunc)
            assert set(OPS_INFO) <= set(info) and set(info) == set(venv.info_row(i))
            for k, v in info.items():
                assert vinfo["_" + k].all(), k
                if k == "filter":
                    assert _same({"x": vinfo[k]["x"][i], "P": vinfo[k]["P"][i]}, v)
                else:
                    assert _same(vinfo[k][i], v), (k, vinfo[k][i], v)
    assert vtrunc.all() and (vinfo["deadline_sigma_km"] > 0).all()


def test_pickle_and_deepcopy_mid_episode_continue_bit_for_bit() -> None:
    env = PlanetNavEnv(ID, **_short(40))
    env.reset(seed=4)
    for k in range(8):
        env.step(_schedule(k))
    clones = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    ref = [env.step(_schedule(k))[:5] for k in range(8, 30)]
    for c in clones:
        got = [c.step(_schedule(k))[:5] for k in range(8, 30)]
        for (o1, r1, *_, i1), (o2, r2, *_, i2) in zip(ref, got, strict=True):
            assert np.array_equal(o1, o2) and r1 == r2
            assert all(_same(i2[k], i1[k]) for k in OPS_INFO)


def test_checkers_pass() -> None:
    from gymnasium.utils.env_checker import check_env as gym_check_env

    gym_check_env(gym.make(ID, **_short(30)).unwrapped)
    sb3_checker = pytest.importorskip("stable_baselines3.common.env_checker")
    sb3_checker.check_env(gym.make(ID, **_short(30)).unwrapped, warn=True)


def test_observation_block_and_decoding_in_physical_units() -> None:
    env = PlanetNavEnv(ID, **_short(40))
    obs, _ = env.reset(seed=1)
    layout = env.layout
    assert layout.n_deadlines == 2 and env.observation_space.shape == (layout.size,)
    ops = layout.to_dict(obs)["operations"]
    np.testing.assert_allclose(ops[:2] * L.OPS_DAYS_SCALE, [10 * DT / 86400, 25 * DT / 86400], rtol=1e-6)
    for k in range(12):
        obs, _, _, _, info = env.step(_schedule(k))
    ops = layout.to_dict(obs)["operations"]
    assert ops[0] == 0.0  # the first deadline has passed
    assert ops[1] * L.OPS_DAYS_SCALE == pytest.approx(13 * DT / 86400, rel=1e-6)
    assert ops[2] * L.OPS_DV_SCALE == pytest.approx(info["dv_lost_m_s"], rel=1e-6)
    assert ops[3] in (0.0, 1.0)
    dec = env.decode_observation(obs)
    assert dec["dv_lost_m_s"] == pytest.approx(info["dv_lost_m_s"], rel=1e-6)
    np.testing.assert_allclose(dec["deadline_time_d"], [0.0, 13 * DT / 86400], rtol=1e-6)
    assert dec["thrusting"] in (False, True)
    denv = PlanetNavEnv(ID, observation="dict", **_short(40))
    dobs, _ = denv.reset(seed=1)
    assert dobs["operations"].shape == (4,) and denv.observation_space.contains(dobs)


def test_per_step_noise_streams_give_the_thrust_error_of_step_k_whatever_happened_before() -> None:
    """With ``per_step`` streams the thrust error at step k is keyed by (seed, k): two runs that differ
    only in an earlier imaging session draw the same error at a later full-thrust step (isotropic PSD,
    so the error does not depend on the slightly different planned direction)."""
    iso = {"thrust_mag_sigma": 0.02, "thrust_point_sigma_deg": math.degrees(0.02)}
    incs = []
    for first in (STAY, 0):
        env = PlanetNavEnv(ID, noise_streams="per_step", **_short(40, **iso))
        env.reset(seed=9)
        acc = env.config.operations.thrust_accel_km_s2
        acts = [STAY, first, first, STAY, STAY, STAY, STAY, STAY]
        rec = _run_recording(env, acts)
        x0, xe0, info, x1 = rec[-1]
        assert info["dv_lost_m_s"] == rec[-2][2]["dv_lost_m_s"]  # full thrust at the last step
        u = xe0[3:] / np.linalg.norm(xe0[3:])
        nominal = np.concatenate([acc * DT * DT / 2 * u, acc * DT * u])
        incs.append(x1 - _gravity_step(env, x0) - nominal)
    np.testing.assert_allclose(incs[0], incs[1], rtol=1e-6, atol=1e-6)  # x ~ 1e8 km: rounding ~ 1e-8 km
    assert np.linalg.norm(incs[0][3:]) > 0
