"""The native vector environment: equivalence with the single environment (the contract), autoreset
modes, pickling, bad input, per-row divergence, the SB3 adapter, and the settled-attitude shortcut."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.core import layout as L
from planetnav_env.core.batch import PARALLEL_MIN_ROWS
from planetnav_env.env import PlanetNavEnv
from planetnav_env.errors import ConfigError, InvalidParameterError, NonFiniteError
from planetnav_env.registration import ENV_IDS
from planetnav_env.vector_env import PlanetNavVectorEnv

SHORT = {"episode_steps": 25}


def _actions(space: gym.Space, n: int, rng: np.random.Generator) -> np.ndarray:
    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(0, space.n, n)
    return rng.uniform(-1.2, 1.2, (n, *space.shape)).astype(np.float32)  # some outside: clipped alike


def _equal_obs(a, b) -> bool:
    if isinstance(a, dict):
        return all(np.array_equal(a[k], b[k]) for k in a)
    return np.array_equal(a, b)


def _row(obs, i):
    return {k: v[i] for k, v in obs.items()} if isinstance(obs, dict) else obs[i]


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_rows_equal_single_envs_bit_for_bit_through_autoresets(env_id: str) -> None:
    """Row i after reset(seed=s) is the single env after reset(seed=s + i), over hundreds of random
    actions with terminations/truncations and next-step autoresets, for every id (every action mode)."""
    n, seed = 3, 11
    kw = dict(SHORT)
    if "MarsApproach" in env_id:
        kw["episode_steps"] = 12  # 1 h integration windows: ambiguity, integration and phases all occur
    venv = gym.make_vec(env_id, num_envs=n, **kw)
    assert isinstance(venv, PlanetNavVectorEnv)
    assert venv.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    singles = [gym.make(env_id, **kw) for _ in range(n)]
    obs, info = venv.reset(seed=seed)
    for i, env in enumerate(singles):
        o, inf = env.reset(seed=seed + i)
        assert _equal_obs(_row(obs, i), o)
        assert info["pos_err_km"][i] == inf["pos_err_km"]
    rng = np.random.default_rng(0)
    pending = [False] * n
    resets = 0
    for _ in range(200):
        acts = _actions(venv.single_action_space, n, rng)
        obs, rew, term, trunc, info = venv.step(acts)
        for i, env in enumerate(singles):
            if pending[i]:
                o, inf = env.reset()
                r, te, tr = 0.0, False, False
                resets += 1
            else:
                o, r, te, tr, inf = env.step(acts[i])
            pending[i] = te or tr
            assert _equal_obs(_row(obs, i), o)
            assert rew[i] == r and term[i] == te and trunc[i] == tr
            assert info["pos_err_km"][i] == inf["pos_err_km"]
            assert np.array_equal(venv.filter_state()[1][i], inf["filter"]["P"])
    assert resets >= n * 5  # the run went through many autoresets


def test_same_step_autoreset_reports_final_observation() -> None:
    n = 2
    venv = PlanetNavVectorEnv(n, autoreset_mode="same_step", episode_steps=5)
    single = PlanetNavEnv(episode_steps=5)
    venv.reset(seed=3)
    single.reset(seed=3)
    for k in range(12):
        obs, _, _term, trunc, info = venv.step(np.array([k % 3, 1]))
        o, _, te, tr, inf = single.step(k % 3)
        if te or tr:
            assert trunc[0] and info["_final_obs"][0]
            assert np.array_equal(info["final_obs"][0], o)
            assert info["final_info"][0]["pos_err_km"] == inf["pos_err_km"]
            o, _ = single.reset()
        assert np.array_equal(obs[0], o)  # the same step's reset observation


def test_parallel_chunks_equal_serial_rows() -> None:
    """Large batches run in chunks on threads; rows are independent, so results equal a batch of one."""
    n = PARALLEL_MIN_ROWS
    venv = PlanetNavVectorEnv(n, scenario="random-cruise", episode_steps=30)
    obs, _ = venv.reset(seed=100)
    rng = np.random.default_rng(1)
    acts = [rng.integers(0, 3, n) for _ in range(8)]
    for a in acts:
        obs, *_ = venv.step(a)
    for i in (0, 17, n - 1):
        env = PlanetNavEnv(scenario="random-cruise", episode_steps=30)
        env.reset(seed=100 + i)
        for a in acts:
            o, *_ = env.step(int(a[i]))
        assert np.array_equal(obs[i], o)


def test_random_cruise_rows_differ_and_memory_per_row_is_small() -> None:
    venv = PlanetNavVectorEnv(4, scenario="random-cruise")
    venv.reset(seed=0)
    epochs = {ep.epoch for ep in venv.core.episodes}
    assert len(epochs) == 4  # each row its own epoch, arc and planets
    assert not np.array_equal(venv.core.eph[0], venv.core.eph[1])
    assert venv.core.bytes_per_row() < 4096  # docs/architecture.md states the bytes per row


@pytest.mark.parametrize("kind", ["single", "vector"])
def test_pickle_and_deepcopy_continue_bit_for_bit(kind: str) -> None:
    env = PlanetNavEnv(**SHORT) if kind == "single" else PlanetNavVectorEnv(3, **SHORT)
    env.reset(seed=4)
    act = 1 if kind == "single" else np.array([0, 1, 2])
    for _ in range(7):
        env.step(act)
    clones = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    ref = [env.step(act)[0] for _ in range(10)]
    for c in clones:
        got = [c.step(act)[0] for _ in range(10)]
        assert all(np.array_equal(a, b) for a, b in zip(ref, got, strict=True))


def test_bad_actions_name_the_row_and_step_nothing() -> None:
    venv = PlanetNavVectorEnv(3, **SHORT)
    venv.reset(seed=0)
    before = venv.core.f.copy()
    with pytest.raises(InvalidParameterError, match="shape"):
        venv.step(np.array([0, 1]))
    with pytest.raises(NonFiniteError, match=r"row 1.*nan"):
        venv.step(np.array([0.0, np.nan, 1.0]))
    with pytest.raises(InvalidParameterError, match=r"row 2.*7"):
        venv.step(np.array([0, 1, 7]))
    assert np.array_equal(venv.core.f, before, equal_nan=True)
    tv = PlanetNavVectorEnv(2, action_mode="torque", **SHORT)
    tv.reset(seed=0)
    before = tv.core.f.copy()
    with pytest.raises(NonFiniteError, match=r"row 1.*inf"):
        tv.step(np.array([[0.1, 0.2, 0.3], [0.0, np.inf, 0.0]]))
    with pytest.raises(InvalidParameterError, match="shape"):
        tv.step(np.zeros((2, 4)))
    assert np.array_equal(tv.core.f, before, equal_nan=True)


def test_a_diverging_row_terminates_alone() -> None:
    venv = PlanetNavVectorEnv(3, divergence_km=5.0e4, **SHORT)
    venv.reset(seed=0)
    venv.core.f[1, L.F_XE] += 1.0e6  # row 1's filter is 10^6 km off: beyond divergence_km
    _, _, term, trunc, info = venv.step(np.array([0, 0, 0]))
    assert term.tolist() == [False, True, False]
    assert not trunc.any()
    assert info["pos_err_km"][1] > 5.0e4
    _obs, rew, term, _, _ = venv.step(np.array([0, 0, 0]))  # row 1 restarts, the others go on
    assert rew[1] == 0.0 and not term.any()
    assert venv.core.i[0, L.I_K] == 2 and venv.core.i[1, L.I_K] == 0


def test_vector_env_conformance() -> None:
    """The vector checks Gymnasium applies to single envs, adapted: spaces contain what reset/step return,
    dtypes and shapes, seeding determinism, and the declared autoreset mode."""
    for env_id in ENV_IDS:
        venv = gym.make_vec(env_id, num_envs=2, episode_steps=4)
        obs, info = venv.reset(seed=1)
        assert venv.observation_space.contains(obs)
        assert isinstance(info, dict) and all(len(v) == 2 for k, v in info.items())
        acts = venv.action_space.sample()
        obs, rew, term, trunc, _ = venv.step(acts)
        assert venv.observation_space.contains(obs)
        assert rew.shape == (2,) and term.dtype == bool and trunc.dtype == bool
        again = gym.make_vec(env_id, num_envs=2, episode_steps=4)
        _o2, _ = again.reset(seed=1)
        o3, *_ = again.step(acts)
        assert _equal_obs(o3, obs)
        assert venv.metadata["autoreset_mode"] in (gym.vector.AutoresetMode.NEXT_STEP,)
    sync = gym.make_vec("planetnav/Cruise-Target-v0", num_envs=2, vectorization_mode="sync", **SHORT)
    assert isinstance(sync, gym.vector.SyncVectorEnv)


def test_settled_substeps_follow_the_fine_integration() -> None:
    """Held target, settled attitude: 10 s sub-steps (the PD command held 10 s instead of 1 s) keep the
    true attitude within 1" (median 0.1") of the 1 s integration, far below the star tracker's 1.4" per
    axis, and the estimate within 1 m, over 300 steps with a slew half way (measured: 0.70" max, 0.085"
    median, 0.2 m)."""
    runs = {}
    for coarse in (10.0, 0.0):
        env = PlanetNavEnv(settled_substep_s=coarse, episode_steps=300)
        env.reset(seed=2)
        qs, xs, settled = [], [], 0
        for k in range(300):
            _, _, _, _, info = env.step(0 if k < 150 else 1)  # a slew to Mars half way
            qs.append(env.truth["q"])
            xs.append(info["filter"]["x"][:3])
            settled += int(env.core.i[0, L.I_SETTLED])
        runs[coarse] = (np.array(qs), np.array(xs), settled)
    q10, x10, settled = runs[10.0]
    q1, x1, _ = runs[0.0]
    assert settled > 200  # the shortcut was taken on most steps
    dots = np.abs(np.sum(q10 * q1, axis=1)).clip(max=1.0)
    angle_arcsec = 2 * np.arccos(dots) * 206264.806
    assert angle_arcsec.max() < 1.0
    assert np.median(angle_arcsec) < 0.1
    assert np.abs(x10 - x1).max() < 1e-3  # km


def test_sb3_adapter_trains_and_reports_terminal_observations() -> None:
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    from planetnav_env.sb3_vec import PlanetNavSB3VecEnv

    vec = VecMonitor(PlanetNavSB3VecEnv(4, seed=0, episode_steps=16))
    obs = vec.reset()
    assert obs.shape == (4, vec.observation_space.shape[0])
    dones_seen = 0
    for k in range(20):
        obs, _rew, done, infos = vec.step(np.full(4, k % 3))
        for i in np.flatnonzero(done):
            dones_seen += 1
            assert infos[i]["terminal_observation"].shape == obs[i].shape
            assert infos[i]["TimeLimit.truncated"] is True
            assert infos[i]["episode"]["l"] == 16
    assert dones_seen == 4
    model = PPO("MlpPolicy", PlanetNavSB3VecEnv(2, seed=1, episode_steps=16), n_steps=32, batch_size=32,
                n_epochs=1, seed=0, device="cpu")  # fmt: skip
    model.learn(64)
    assert model.num_timesteps >= 64


def test_core_pulsar_visibility_equals_the_numpy_rule() -> None:
    """The core's per-row pulsar visibility (Sun avoidance, occultation by the central body) is held to
    ``sensors.pulsar.pulsar_visibility`` (its numpy oracle) at random geometries near Mars."""
    from planetnav_env.sensors import pulsar as psr
    from planetnav_env.sensors.pulsar import pulsar_visibility_row

    rng = np.random.default_rng(7)
    det = psr.DEFAULT_DETECTOR
    names = ("B0531+21", "B1937+21", "B1821-24")
    dirs = np.array([psr.pulsar(n).direction for n in names])
    mars = np.array([2.0e8, 0.5e8, 0.1e8])
    radius = psr.mars_radius_km()
    codes = {L.REASON_VISIBLE: 0, L.REASON_SUN_EXCLUSION: 0, L.REASON_OCCULTED: 0}
    for _ in range(400):
        r = mars + rng.normal(size=3) * rng.choice([5e3, 5e4, 5e8])
        want = psr.pulsar_visibility(r, names, det, mars, radius)
        for j in range(len(names)):
            got = pulsar_visibility_row(r, dirs[j], np.radians(det.sun_avoidance_deg), mars, radius, True)
            expect = (
                L.REASON_SUN_EXCLUSION
                if want.sun_blocked[0, j]
                else (L.REASON_OCCULTED if want.occulted[0, j] else L.REASON_VISIBLE)
            )
            assert got == expect
            codes[got] += 1
    assert all(v > 0 for v in codes.values())  # every branch was exercised


def test_torque_action_scale_multiplies_the_commanded_torque():
    """Action a under torque_action_scale 0.5 is action a / 2 under scale 1 (powers of two: exact), in both
    torque modes; the penalty is on the commanded fraction of the limit. Bad scales name the value."""
    rng = np.random.default_rng(4)
    for mode in ("torque", "target+torque"):
        half = PlanetNavVectorEnv(
            2, action_mode=mode, episode_steps=30, torque_action_scale=0.5, torque_penalty=1.0
        )
        full = PlanetNavVectorEnv(2, action_mode=mode, episode_steps=30, torque_penalty=1.0)
        oh, _ = half.reset(seed=8)
        of, _ = full.reset(seed=8)
        for _ in range(25):
            a = rng.uniform(-1, 1, half.action_space.shape)
            b = a.copy()
            b[:, -3:] *= 0.5
            oh, rh, *_ = half.step(a)
            of, rf, *_ = full.step(b)
            np.testing.assert_array_equal(oh, of)
            np.testing.assert_array_equal(rh, rf)
    for bad in (0.0, 1.5, float("nan"), True):
        with pytest.raises(ConfigError, match="torque_action_scale"):
            PlanetNavVectorEnv(1, action_mode="torque", torque_action_scale=bad)
