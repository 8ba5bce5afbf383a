"""The native vector environment: equivalence with the single environment (the contract), autoreset
modes, pickling, bad input, per-row divergence, the SB3 adapter, and the settled-attitude shortcut."""

from __future__ import annotations

import copy
import pickle

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.batch import PARALLEL_MIN_ROWS
from planetnav_env.core import layout as L
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.registration import ENV_IDS, id_options
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import ConfigError, InvalidParameterError, NonFiniteError, UnknownOptionError

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


def test_copies_and_the_callers_arrays_reuse_the_compiled_step() -> None:
    """A pickled or deep-copied env, a read-only or strided mask of rows and integer actions all step
    through the kernel already compiled: numba would type each as a new signature and compile the whole
    step again (minutes the first time, on every machine)."""
    from planetnav_env.core import kernels as K

    env = PlanetNavVectorEnv(3, **SHORT)
    env.reset(seed=4)
    env.step(np.array([0, 1, 2]))
    compiled = set(K.step_range_arrays.signatures)
    read_only_mask = np.ones(3, dtype=bool)
    read_only_mask.flags.writeable = False
    strided_mask = np.ones(6, dtype=bool)[::2]
    for c in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        assert not c.core.params.stars.dirs.flags.writeable
        c.step(np.array([2, 1, 0]))
        c.step_rows(np.array([0, 0, 1]), read_only_mask)
        c.step_rows(np.array([1, 0, 1]), strided_mask)
        c.core.step(np.array([[0], [1], [2]], dtype=np.int64))
    assert set(K.step_range_arrays.signatures) == compiled


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
        assert isinstance(info, dict)
        # Every key (and every key of a nested dict, Gymnasium's convention for dict values) has 2 rows.
        rows = [len(x) for v in info.values() for x in (v.values() if isinstance(v, dict) else [v])]
        assert set(rows) == {2}
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
    pytest.importorskip("stable_baselines3", reason="the SB3 adapter needs the [train] extra")
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor

    from planetnav_train.sb3_vec import PlanetNavSB3VecEnv

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


#: The info keys that docs/environment.md ("Info keys") documents, for the single and the vector env.
INFO_KEYS = {
    "pos_err_km", "vel_err_km_s", "nees", "pos_sigma_km", "measured", "rejected", "target", "target_index",
    "sensor", "ambiguous_skipped", "visibility", "visibility_code", "slewing", "attitude_err_arcsec",
    "time_s", "filter",
}  # fmt: skip
#: The operations scenarios' extra keys (``EnvConfig.operations`` set), documented in the same table.
OPERATIONS_INFO_KEYS = {"dv_lost_m_s", "deadline_sigma_km", "deadline_err_km", "objective"}


def _same_value(vector_value, single_value) -> bool:
    """A row's array entry equals the single env's Python value (names: the same str or None)."""
    if single_value is None or isinstance(single_value, str):
        return vector_value == single_value
    if isinstance(single_value, np.ndarray):  # per-row vectors (the operations deadlines)
        return np.array_equal(vector_value, single_value, equal_nan=True)
    if isinstance(single_value, float) and np.isnan(single_value):
        return bool(np.isnan(vector_value))
    return vector_value == single_value


def _assert_rows_match(vinfo: dict, infos: list[dict], keys: set[str]) -> None:
    assert {k for k in vinfo if not k.startswith("_")} == keys
    for single in infos:
        assert set(single) == keys
    for k in keys:
        assert vinfo["_" + k].dtype == bool and vinfo["_" + k].all(), k  # every row has every key
    for i, single in enumerate(infos):
        for k, value in single.items():
            if k == "filter":
                assert np.array_equal(vinfo[k]["x"][i], value["x"])
                assert np.array_equal(vinfo[k]["P"][i], value["P"])
            else:
                assert _same_value(vinfo[k][i], value), (k, i, vinfo[k][i], value)


@pytest.mark.parametrize("env_id", list(ENV_IDS))
def test_vector_info_has_the_single_env_keys_row_for_row(env_id: str) -> None:
    """One documented set of info keys: the vector env's are the single env's, as arrays over the rows
    (names as object arrays, the filter as (N, 6) and (N, 6, 6)), each value equal to the single env's
    row; the README's ``info["target"]`` works on both."""
    n, seed = 3, 21
    steps = 8 * id_options(env_id).get("decision_steps", 1)  # 8 decisions
    venv = gym.make_vec(env_id, num_envs=n, episode_steps=steps)
    singles = [gym.make(env_id, episode_steps=steps) for _ in range(n)]
    keys = INFO_KEYS | (OPERATIONS_INFO_KEYS if venv.unwrapped.config.operations is not None else set())
    _, vinfo = venv.reset(seed=seed)
    infos = [env.reset(seed=seed + i)[1] for i, env in enumerate(singles)]
    _assert_rows_match(vinfo, infos, keys)
    rng = np.random.default_rng(3)
    names_seen = set()
    for _ in range(6):
        acts = _actions(venv.single_action_space, n, rng)
        *_, vinfo = venv.step(acts)
        infos = [env.step(acts[i])[4] for i, env in enumerate(singles)]
        _assert_rows_match(vinfo, infos, keys)
        names_seen.update(vinfo["target"].tolist())
    assert vinfo["target"].dtype == object
    # In torque and hybrid modes `target` is the planet the camera sees nearest its boresight, None in
    # these short random episodes; the target modes name the chosen target.
    if venv.unwrapped.config.action_mode not in ("torque", "hybrid"):
        assert names_seen - {None}  # real names, not codes
    names = venv.unwrapped.config.planets + venv.unwrapped.config.pulsars
    for i in range(n):
        code = vinfo["target_index"][i]
        assert vinfo["target"][i] == (names[code] if code >= 0 else None)
        assert vinfo["visibility"][i] == L.REASONS[vinfo["visibility_code"][i]]
        row = venv.unwrapped.info_row(i)
        assert set(row) == keys and row["target_index"] == infos[i]["target_index"]


def test_vector_env_takes_an_env_id_and_reports_the_episode_length() -> None:
    """An id stands for its registered options (as gym.make reads them), in the vector env and the SB3
    adapter alike; ``spec.max_episode_steps`` is the env's own ``episode_steps``."""
    venv = PlanetNavVectorEnv(2, "planetnav/MarsApproach-Tasking-v0", episode_steps=5)
    made = gym.make_vec("planetnav/MarsApproach-Tasking-v0", num_envs=2, episode_steps=5)
    assert venv.config == made.unwrapped.config and venv.config.pulsars == ("B0531+21", "B1937+21")
    assert made.spec.max_episode_steps == 5
    assert gym.make_vec("planetnav/MarsApproach-Tasking-v0", num_envs=2).spec.max_episode_steps == 1128
    with pytest.raises(ConfigError, match="planetnav/Nope-v0"):
        PlanetNavVectorEnv(2, "planetnav/Nope-v0")
    with pytest.raises(UnknownOptionError, match="got an unexpected keyword argument 'frameskip'"):
        gym.make_vec("planetnav/Cruise-Target-v0", num_envs=2, frameskip=4)
    pytest.importorskip("stable_baselines3", reason="the SB3 adapter needs the [train] extra")
    from planetnav_train.sb3_vec import PlanetNavSB3VecEnv

    sb3 = PlanetNavSB3VecEnv(4, "planetnav/MarsApproach-Tasking-v0")
    assert sb3.config == PlanetNavVectorEnv(4, "planetnav/MarsApproach-Tasking-v0").config
    assert sb3.reset().shape == (4, *sb3.observation_space.shape)


def test_vector_reset_rejects_unknown_options_by_name() -> None:
    venv = PlanetNavVectorEnv(2, **SHORT)
    with pytest.raises(InvalidParameterError, match=r"\['foo'\].*reset_mask"):
        venv.reset(seed=0, options={"foo": 1})
    with pytest.raises(InvalidParameterError, match="must be a dict"):
        venv.reset(seed=0, options=["reset_mask"])
    venv.reset(seed=0)
    _, info = venv.reset(options={"reset_mask": np.array([True, False])})  # the one known option
    assert info["pos_err_km"].shape == (2,)


def test_vector_reset_seeds_rows_by_the_rule_and_names_a_short_seed_list() -> None:
    """``seed=s`` seeds row n with s + n (the device env's bank uses the same rule: row_seeds)."""
    venv, single = PlanetNavVectorEnv(2, **SHORT), PlanetNavEnv(**SHORT)
    obs, _ = venv.reset(seed=[None, 12])
    o1, _ = single.reset(seed=12)
    assert obs[1].tobytes() == o1.tobytes()
    obs, _ = venv.reset(seed=11)
    assert obs[1].tobytes() == o1.tobytes()
    with pytest.raises(InvalidParameterError, match="seed list must have 2 entries, got 3"):
        venv.reset(seed=[1, 2, 3])


@pytest.mark.skipif(not hasattr(gym.vector.AutoresetMode, "DISABLED"), reason="Gymnasium < 1.1")
def test_disabled_autoreset_leaves_resets_to_the_caller() -> None:
    """``autoreset_mode="disabled"`` (TorchRL's preferred mode): a row that ended refuses to step, naming
    it, until the caller resets it with ``reset_mask``; the rows then go on as ``next_step`` rows do."""
    acts = np.array([0, 1])
    off = gym.make_vec("planetnav/Cruise-Target-v0", num_envs=2, autoreset_mode="disabled", episode_steps=3)
    ref = gym.make_vec("planetnav/Cruise-Target-v0", num_envs=2, episode_steps=3)
    assert off.metadata["autoreset_mode"] == gym.vector.AutoresetMode.DISABLED
    off.reset(seed=4)
    ref.reset(seed=4)
    for _ in range(3):
        obs, _, _, trunc, _ = off.step(acts)
        assert np.array_equal(obs, ref.step(acts)[0])
    assert trunc.all()
    with pytest.raises(RuntimeError, match=r"rows \[0, 1\] have ended.*reset_mask"):
        off.step(acts)
    obs, _ = off.reset(options={"reset_mask": np.array([True, True])})
    assert np.array_equal(obs, ref.step(acts)[0])  # next_step's autoreset observation
    assert np.array_equal(off.step(acts)[0], ref.step(acts)[0])


def test_info_keys_table_in_the_docs_lists_exactly_the_keys() -> None:
    """docs/environment.md's "Info keys" table is the one documented set: it names every key, no other."""
    from pathlib import Path

    text = (Path(__file__).parents[2] / "docs" / "environment.md").read_text()
    section = text.split("## Info keys", 1)[1].split("\n## ", 1)[0]
    documented = {line.split("`")[1] for line in section.splitlines() if line.startswith("| `")}
    assert documented == INFO_KEYS | OPERATIONS_INFO_KEYS


def _assert_numeric_form(numeric: dict, full: dict) -> None:
    """``numeric`` is ``full`` without the names, with the filter flat: same values, no object arrays."""
    private = {k for k in numeric if k.startswith("_")}
    expected = (set(full) - {"target", "sensor", "visibility", "filter"}) | {"filter_x", "filter_P"}
    assert set(numeric) - private == {k for k in expected if not k.startswith("_")}
    for k in set(numeric) - private:
        value = numeric[k]
        ref = full["filter"]["x" if k == "filter_x" else "P"] if k.startswith("filter_") else full[k]
        assert not isinstance(value, dict) and np.asarray(value).dtype != object, k
        assert np.asarray(value).dtype == np.asarray(ref).dtype, k
        assert np.array_equal(value, ref, equal_nan=True), k


@pytest.mark.parametrize("env_id", ["planetnav/Cruise-Target-v0", "planetnav/ThrustArc-TCM-v0"])
def test_numeric_info_keys_are_the_default_ones_without_names_and_flat(env_id: str) -> None:
    """``info_keys="numeric"`` (for TorchRL's same_step reader, docs/environment.md): the default keys
    without ``target``, ``sensor``, ``visibility``, the filter as ``filter_x`` / ``filter_P``, row for row
    equal to the default ones, masks included, and ``final_info`` rows in the same form; the steps
    themselves are unchanged. A value other than "all" or "numeric" raises naming it."""
    kw = dict(num_envs=3, autoreset_mode="same_step", episode_steps=4)
    full = gym.make_vec(env_id, **kw)
    numeric = gym.make_vec(env_id, info_keys="numeric", **kw)
    assert numeric.unwrapped.info_keys == "numeric" and full.unwrapped.info_keys == "all"
    _, finfo = full.reset(seed=5)
    _, ninfo = numeric.reset(seed=5)
    _assert_numeric_form(ninfo, finfo)
    assert all(ninfo["_" + k].all() for k in ninfo if not k.startswith("_"))  # each key's mask, all True
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(9):
        acts = _actions(full.single_action_space, 3, rng)
        fobs, frew, fterm, ftrunc, finfo = full.step(acts)
        nobs, nrew, nterm, ntrunc, ninfo = numeric.step(acts)
        assert _equal_obs(nobs, fobs) and np.array_equal(nrew, frew)
        assert np.array_equal(nterm, fterm) and np.array_equal(ntrunc, ftrunc)
        rows = np.flatnonzero(fterm | ftrunc)
        assert ("final_info" in ninfo) == ("final_info" in finfo) == (rows.size > 0)
        for r in rows:
            ended += 1
            assert _equal_obs(ninfo["final_obs"][r], finfo["final_obs"][r])
            assert set(finfo["final_info"][r]) == set(full.unwrapped.info_row(r))
            row = {k: np.asarray(v) for k, v in finfo["final_info"][r].items() if k != "filter"}
            _assert_numeric_form(
                {k: np.asarray(v) for k, v in ninfo["final_info"][r].items()},
                {**row, "filter": finfo["final_info"][r]["filter"]},
            )
        _assert_numeric_form(*({k: v for k, v in i.items() if "final_" not in k} for i in (ninfo, finfo)))
        assert all(ninfo["_" + k].all() for k in ninfo if not k.startswith("_") and "final_" not in k)
    assert ended >= 3  # two episode ends of 3 rows were inside the run
    for bad in ("names", "ALL", None, 1):
        with pytest.raises(
            InvalidParameterError, match=rf"info_keys must be one of \['all', 'numeric'\], got {bad!r}"
        ):
            PlanetNavVectorEnv(2, info_keys=bad)
    with pytest.raises(InvalidParameterError, match="info_keys"):
        gym.make_vec("planetnav/Cruise-Target-v0", num_envs=2, info_keys="tensor")


def _snapshot(info: dict) -> dict:
    """A deep copy of an info (arrays copied), to compare the returned one with later."""
    return copy.deepcopy(info)


def _assert_same_info(now: dict, then: dict) -> None:
    assert list(now) == list(then)
    for k, v in then.items():
        if isinstance(v, dict):
            _assert_same_info(now[k], v)
        elif isinstance(v, np.ndarray) and v.dtype != object:
            assert now[k].dtype == v.dtype and np.array_equal(now[k], v, equal_nan=True), k
        elif isinstance(v, np.ndarray):
            assert now[k].tolist() == v.tolist(), k
        else:
            assert now[k] == v or (v != v and now[k] != now[k]), k  # NaN == NaN here


@pytest.mark.parametrize("env_id", ["planetnav/Cruise-Target-v0", "planetnav/ThrustArc-TCM-v0"])
def test_info_values_do_not_alias_state_a_later_step_overwrites(env_id: str) -> None:
    """An info kept from step k is unchanged after step k + 1 and k + 2 (the values are new arrays, not
    views of the state the kernels write), for the single env and both vector key sets; the vector
    env's numeric dtypes are those of the single env's values stacked over the rows."""
    seed, n = 11, 2
    rng = np.random.default_rng(0)
    single = gym.make(env_id, **SHORT).unwrapped
    venvs = [gym.make_vec(env_id, num_envs=n, info_keys=keys, **SHORT) for keys in ("all", "numeric")]
    kept = [venv.reset(seed=seed)[1] for venv in venvs] + [single.reset(seed=seed)[1]]
    kept_snaps = [_snapshot(i) for i in kept]
    for _ in range(3):
        acts = _actions(venvs[0].single_action_space, n, rng)
        infos = [venv.step(acts)[4] for venv in venvs] + [single.step(acts[0])[4]]
        for now, then in zip(infos, kept, strict=True):
            # the state moved on (else this test could not fail) ...
            assert np.all(np.asarray(now["time_s"]) > np.asarray(then["time_s"]))
        for old, snap in zip(kept, kept_snaps, strict=True):
            _assert_same_info(old, snap)  # ... and the info kept from the step before did not
        kept, kept_snaps = infos, [_snapshot(i) for i in infos]
        rows = [venvs[0].unwrapped.info_row(r) for r in range(n)]
        for key, value in infos[0].items():
            if key.startswith("_") or key in ("filter", "target", "sensor", "visibility"):
                continue
            assert value.dtype == np.asarray([row[key] for row in rows]).dtype, key
    for venv in venvs:
        venv.close()
