"""Per-step noise streams (``EnvConfig.noise_streams = "per_step"``, common random numbers): the SplitMix64
derivation against a pure-Python reference, the distribution of the noise it gives, independence from
the history of the episode, equality of the vector env's rows with single envs, and the evaluation
option of ``train.py``."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from numba import njit
from scipy import stats

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.core import rng as prng
from planetnav_env.envs.env import PlanetNavEnv
from planetnav_env.envs.vector_env import PlanetNavVectorEnv
from planetnav_env.errors import ConfigError
from planetnav_train.cli import main
from planetnav_train.config import parse_config
from planetnav_train.evaluate import evaluation_env

MASK = (1 << 64) - 1


# --------------------------------------------------------------------------------------------------------
# The derivation
# --------------------------------------------------------------------------------------------------------
def _mix64_ref(z: int) -> int:
    """SplitMix64's finaliser, from the published algorithm (Python ints masked to 64 bits)."""
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
    return z ^ (z >> 31)


def _substream_ref(key, k: int, stream: int) -> list[int]:
    key = [int(w) for w in key]
    x = _mix64_ref(key[3] ^ k ^ (stream << 40))
    x = _mix64_ref(key[2] ^ x)
    x = _mix64_ref(key[1] ^ x)
    x = key[0] ^ x
    out = []
    for _ in range(4):
        x = (x + 0x9E3779B97F4A7C15) & MASK
        out.append(_mix64_ref(x))
    return out


@njit(cache=True)
def _substream(key, k, stream):
    out = np.empty(4, dtype=np.uint64)
    prng.substream(key, k, stream, out)
    return out


@njit(cache=True)
def _first_normals(key, n_steps, stream):
    """The first normal of ``stream`` at each step 0..n_steps-1 (what a sensor's first draw would be)."""
    out = np.empty(n_steps)
    s = np.empty(4, dtype=np.uint64)
    for k in range(n_steps):
        prng.substream(key, k, stream, s)
        out[k] = prng.standard_normal(s)
    return out


def test_substream_matches_the_reference_and_leaves_the_key_alone() -> None:
    rng = np.random.default_rng(1)
    for _ in range(20):
        key = prng.seed_state(rng)
        before = key.copy()
        k, stream = int(rng.integers(0, 2**40)), int(rng.integers(0, 2**24))
        got = _substream(key, k, stream)
        assert [int(w) for w in got] == _substream_ref(key, k, stream)
        assert np.array_equal(key, before)


def test_substreams_are_distinct_per_step_stream_and_key() -> None:
    rng = np.random.default_rng(2)
    keys = [prng.seed_state(rng) for _ in range(3)]
    states = {
        tuple(int(w) for w in _substream(key, k, stream))
        for key in keys
        for k in range(200)
        for stream in (1, 2, 3, 16, 17)
    }
    assert len(states) == 3 * 200 * 5


def test_per_step_normals_are_standard_and_independent() -> None:
    """First draws over 100,000 steps: N(0, 1) by Kolmogorov-Smirnov, no lag-1 correlation along the
    steps and none between two sensors' streams at the same step (bounds: 5 standard errors)."""
    key = prng.seed_state(np.random.default_rng(3))
    n = 100_000
    a = _first_normals(key, n, 1)
    b = _first_normals(key, n, 2)
    assert stats.kstest(a, "norm").pvalue > 1e-3
    assert abs(a.mean()) < 5 / np.sqrt(n) and abs(a.var() - 1.0) < 5 * np.sqrt(2 / n)
    assert abs(np.corrcoef(a[1:], a[:-1])[0, 1]) < 5 / np.sqrt(n)
    assert abs(np.corrcoef(a, b)[0, 1]) < 5 / np.sqrt(n)


# --------------------------------------------------------------------------------------------------------
# The environment
# --------------------------------------------------------------------------------------------------------
def _rate_noise_run(noise_streams: str, actions: np.ndarray, seed: int = 5) -> np.ndarray:
    """Reported minus true body rates [rad/s] after each step: exactly the rate sensor's noise."""
    env = PlanetNavEnv(EnvConfig(noise_streams=noise_streams, episode_steps=len(actions) + 1))
    env.reset(seed=seed)
    f = env.core.f
    out = []
    for a in actions:
        env.step(int(a))
        out.append(f[0, L.F_WM : L.F_WM + 3] - f[0, L.F_W : L.F_W + 3])
    return np.array(out)


def test_per_step_noise_does_not_depend_on_the_history() -> None:
    """Two action sequences on one seed: with per-step streams the rate sensor's noise is the same at
    every step whatever was pointed at before (a slew changes the stars in view, a measurement draws
    camera noise); with the sequential stream the second sequence's draws shift and the noise differs."""
    rng = np.random.default_rng(0)
    a = np.zeros(40, dtype=int)
    b = rng.integers(0, 3, 40)
    b[0] = 0
    per_a, per_b = _rate_noise_run("per_step", a), _rate_noise_run("per_step", b)
    seq_a, seq_b = _rate_noise_run("sequential", a), _rate_noise_run("sequential", b)
    # equal up to the rounding of (rate + noise) - rate at different true rates
    np.testing.assert_allclose(per_a, per_b, rtol=1e-6, atol=0)
    assert not np.allclose(seq_a[-10:], seq_b[-10:], rtol=1e-2, atol=0)
    assert np.array_equal(seq_a[0], seq_b[0])  # the same first step: the sequential streams agree there
    sigma = np.radians(EnvConfig().attitude.rate_noise_deg_s)
    assert 0.5 < np.std(per_a) / sigma < 1.5  # noise of the configured size, not zeros


def test_per_step_noise_is_reproducible_and_not_the_sequential_draw() -> None:
    actions = np.array([0] * 10 + [1] * 10 + [2] * 10)
    first, again = _rate_noise_run("per_step", actions), _rate_noise_run("per_step", actions)
    assert np.array_equal(first, again)
    assert not np.allclose(first, _rate_noise_run("sequential", actions))
    assert not np.allclose(first, _rate_noise_run("per_step", actions, seed=6))


@pytest.mark.parametrize(
    "env_id",
    ["planetnav/MarsApproach-Tasking-v0", "planetnav/RandomCruise-Target-v0", "planetnav/Cruise-Torque-v0"],
)
def test_per_step_rows_equal_single_envs_bit_for_bit(env_id: str) -> None:
    """The vector env's rows with per-step streams are the single env's (pulsars included)."""
    n, seed = 3, 21
    kw = {"episode_steps": 12 if "MarsApproach" in env_id else 25, "noise_streams": "per_step"}
    venv = gym.make_vec(env_id, num_envs=n, **kw)
    assert isinstance(venv, PlanetNavVectorEnv)
    singles = [gym.make(env_id, **kw) for _ in range(n)]
    venv.reset(seed=seed)
    for i, env in enumerate(singles):
        env.reset(seed=seed + i)
    rng = np.random.default_rng(1)
    space = venv.single_action_space
    pending = [False] * n
    for _ in range(60):
        if isinstance(space, gym.spaces.Discrete):
            acts = rng.integers(0, space.n, n)
        else:
            acts = rng.uniform(-1, 1, (n, *space.shape)).astype(np.float32)
        obs, rew, _, _, info = venv.step(acts)
        for i, env in enumerate(singles):
            if pending[i]:
                o, inf = env.reset()
                r = 0.0
                te = tr = False
            else:
                o, r, te, tr, inf = env.step(acts[i])
            pending[i] = te or tr
            assert np.array_equal(obs[i], o)
            assert rew[i] == r and info["pos_err_km"][i] == inf["pos_err_km"]


def test_bad_noise_streams_name_the_value() -> None:
    with pytest.raises(ConfigError, match=r"noise_streams.*'per_episode'"):
        EnvConfig(noise_streams="per_episode")
    with pytest.raises(ConfigError, match="noise_streams"):
        EnvConfig.from_dict({"noise_streams": 1})


# --------------------------------------------------------------------------------------------------------
# train.py: the evaluation option
# --------------------------------------------------------------------------------------------------------


def test_evaluation_env_overrides_only_what_is_given() -> None:
    base = EnvConfig(episode_steps=30)
    assert evaluation_env(base, None, None) is base
    got = evaluation_env(base, 7, "per_step")
    assert (got.episode_steps, got.noise_streams) == (7, "per_step")
    assert evaluation_env(base, None, "per_step").episode_steps == 30


def test_eval_noise_streams_is_validated() -> None:
    with pytest.raises(ConfigError, match=r"config\.eval: noise_streams.*'shared'"):
        parse_config({"eval": {"noise_streams": "shared"}})
    assert parse_config({"eval": {"noise_streams": "per_step"}}).eval.noise_streams == "per_step"


def test_compare_with_per_step_noise_changes_the_draw_not_the_seeds(tmp_path: Path) -> None:
    """``--noise-streams per_step`` reaches the environment (other errors on the same seeds), and the
    report says the agents shared their noise."""
    common = ["compare", "--agents", "greedy", "--episodes", "2", "--episode-steps", "30", "--no-progress"]
    assert main([*common, "--json", str(tmp_path / "seq.json")]) == 0
    crn_args = ["--noise-streams", "per_step", "--json", str(tmp_path / "crn.json")]
    crn_args += ["--report", str(tmp_path / "rep")]
    assert main([*common, *crn_args]) == 0
    seq = json.loads((tmp_path / "seq.json").read_text())["agents"]["greedy"]
    crn = json.loads((tmp_path / "crn.json").read_text())["agents"]["greedy"]
    assert seq["seed"] == crn["seed"] and seq["episodes"] == crn["episodes"] == 2
    assert seq["per_episode_mean_pos_err_km"] != crn["per_episode_mean_pos_err_km"]
    assert "per-step noise streams" in (tmp_path / "rep" / "report.md").read_text()
    assert (seq["noise_streams"], crn["noise_streams"]) == ("sequential", "per_step")


def test_paired_notes_evaluations_that_share_no_noise(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], research_command
) -> None:
    paired = research_command("paired").main
    entry = {"episodes": 2, "seed": 10000, "mean_pos_err_km": 1.0, "per_episode_mean_pos_err_km": [1.0, 1.0]}
    (tmp_path / "a.json").write_text(json.dumps({"agents": {"x": {**entry, "noise_streams": "per_step"}}}))
    (tmp_path / "b.json").write_text(json.dumps({"agents": {"x": entry}}))  # written before the key
    (tmp_path / "c.json").write_text(json.dumps({"agents": {"x": {**entry, "noise_streams": "per_step"}}}))
    assert paired(["--a", f"{tmp_path / 'a.json'}:x", "--b", f"{tmp_path / 'b.json'}:x"]) == 0
    assert "share no sensor noise" in capsys.readouterr().out
    assert paired(["--a", f"{tmp_path / 'a.json'}:x", "--b", f"{tmp_path / 'c.json'}:x"]) == 0
    assert "share no sensor noise" not in capsys.readouterr().out
