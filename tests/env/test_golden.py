"""Bit identity: golden hashes of a fixed rollout per environment id, single and vector.

Any change that alters a number the environments produce (an observation, a reward, a flag, an info
value, the filter's estimate and covariance, the true state) changes a hash here. Refactors must keep
every hash; a change that is meant to alter numbers regenerates the file and says why in its commit:

    PLANETNAV_UPDATE_GOLDEN=1 python -m pytest tests/env/test_golden.py

Each quantity has its own hash (and each info key its own), so a new info key is allowed and a
failure names what moved. A rollout covers a whole episode plus a few steps, so truncation and the
vector env's autoreset are inside it.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest

import planetnav_env  # noqa: F401  (registers the ids)
from planetnav_env.envs.registration import ENV_IDS, id_options

GOLDEN = Path(__file__).parents[1] / "golden" / "rollout_hashes.json"
UPDATE = os.environ.get("PLANETNAV_UPDATE_GOLDEN") == "1"
SEED = 7
N_VEC = 3

#: The flight world on each scenario (cruise, random cruise, Mars approach, thrust arc).
FLIGHT = ("Cruise-Target-v2", "RandomCruise-Target-v2", "MarsApproach-Tasking-v2", "ThrustArc-TCM-v2")

#: (name, id, extra options): every registered id, plus the per-step noise streams on the cruise, plus the
#: flight world on each scenario.
CASES = (
    [(env_id, env_id, {}) for env_id in ENV_IDS]
    + [("planetnav/Cruise-Target-v0+per_step", "planetnav/Cruise-Target-v0", {"noise_streams": "per_step"})]
    + [(f"planetnav/{name}+flight", f"planetnav/{name}", {"world": "flight"}) for name in FLIGHT]
)


class _Hashes:
    """One running sha256 per named quantity."""

    def __init__(self) -> None:
        self._h: dict[str, Any] = {}

    def add(self, name: str, value: Any) -> None:
        if isinstance(value, dict):
            for k in sorted(value):
                self.add(f"{name}.{k}", value[k])
            return
        h = self._h.setdefault(name, hashlib.sha256())
        h.update(_canonical(value))

    def digests(self) -> dict[str, str]:
        return {k: h.hexdigest() for k, h in sorted(self._h.items())}


def _canonical(value: Any) -> bytes:
    if value is None:
        return b"<None>"
    if isinstance(value, str):
        return b"s:" + value.encode()
    a = np.asarray(value)
    if a.dtype == object:
        return b"o:" + b"|".join(_canonical(v) for v in a.ravel())
    if a.dtype.kind in "US":
        return b"u:" + "|".join(map(str, a.ravel())).encode()
    # float64 holds every bool/int/float32 exactly; shape is part of the value
    return f"{a.shape}".encode() + np.ascontiguousarray(a, dtype="<f8").tobytes()


def _actions(space: gym.Space, rng: np.random.Generator, n: int | None) -> Any:
    shape = () if n is None else (n,)
    if isinstance(space, gym.spaces.Discrete):
        return rng.integers(0, space.n, size=shape) if n is not None else int(rng.integers(0, space.n))
    return rng.uniform(-1.0, 1.0, size=shape + space.shape).astype(space.dtype)


def _record_step(h: _Hashes, obs: Any, reward: Any, terminated: Any, truncated: Any, info: dict) -> None:
    h.add("obs", obs)
    h.add("reward", reward)
    h.add("terminated", terminated)
    h.add("truncated", truncated)
    h.add("info", info)


def _steps(env_id: str) -> int:
    kw = id_options(env_id)
    return -(-int(kw.get("episode_steps", 1440)) // int(kw.get("decision_steps", 1))) + 5


def rollout_single(env_id: str, options: dict) -> dict[str, Any]:
    env = gym.make(env_id, **options)
    h = _Hashes()
    rng = np.random.default_rng(12345)
    obs, info = env.reset(seed=SEED)
    h.add("obs", obs)
    h.add("info", info)
    h.add("truth", env.unwrapped.truth)
    for _ in range(_steps(env_id)):
        obs, reward, terminated, truncated, info = env.step(_actions(env.action_space, rng, None))
        _record_step(h, obs, reward, terminated, truncated, info)
        h.add("truth", env.unwrapped.truth)
        if terminated or truncated:
            obs, info = env.reset()
            h.add("obs", obs)
            h.add("info", info)
    env.close()
    return h.digests()


def rollout_vector(env_id: str, options: dict) -> dict[str, Any]:
    venv = gym.make_vec(env_id, num_envs=N_VEC, **options)
    h = _Hashes()
    rng = np.random.default_rng(12345)
    obs, info = venv.reset(seed=SEED)
    h.add("obs", obs)
    h.add("info", info)
    for _ in range(_steps(env_id)):
        obs, reward, terminated, truncated, info = venv.step(_actions(venv.single_action_space, rng, N_VEC))
        _record_step(h, obs, reward, terminated, truncated, info)
        x, p = venv.unwrapped.filter_state()
        h.add("filter.x", x)
        h.add("filter.P", p)
        for r in range(N_VEC):
            h.add("truth", venv.unwrapped.core.truth_row(r))
    venv.close()
    return h.digests()


def _load() -> dict:
    return json.loads(GOLDEN.read_text()) if GOLDEN.exists() else {}


@pytest.mark.parametrize("kind", ["single", "vector"])
@pytest.mark.parametrize("name,env_id,options", CASES, ids=[c[0] for c in CASES])
def test_rollout_hashes_unchanged(name: str, env_id: str, options: dict, kind: str) -> None:
    got = (rollout_single if kind == "single" else rollout_vector)(env_id, options)
    if UPDATE:
        data = _load()
        data.setdefault(name, {})[kind] = got
        GOLDEN.parent.mkdir(exist_ok=True)
        GOLDEN.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n")
        return
    want = _load().get(name, {}).get(kind)
    assert want, f"no golden hashes for {name} ({kind}): run with PLANETNAV_UPDATE_GOLDEN=1"
    missing = sorted(set(want) - set(got))
    changed = sorted(k for k in want if k in got and got[k] != want[k])
    assert not missing and not changed, (
        f"{name} ({kind}): quantities that changed {changed}, that disappeared {missing}"
    )


def test_canonical_form_tells_values_apart() -> None:
    """The hash input separates what must differ (a failing hash must mean a changed number)."""
    assert _canonical(np.float32(1.0)) == _canonical(1.0)
    assert _canonical(1.0) != _canonical(np.nextafter(1.0, 2.0))
    assert _canonical(np.zeros(3)) != _canonical(np.zeros((3, 1)))
    assert _canonical(None) != _canonical(0.0)
    assert _canonical("a") != _canonical("b")
