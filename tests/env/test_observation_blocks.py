"""The optional observation blocks (``core.layout.OBSERVATION_BLOCKS``), written by the compiled kernels
(``core/observation.py``) for every environment.

* The history blocks (``since_measured``, ``image_log``, ``residual_log``) and ``position_correlation``
  equal, bit for bit, numpy oracles written here from their definitions (the counts advanced from each
  physics step's outcome in the state), over a rollout with image failures, pulsars, holds and resets.
* A block is declared once: the product code of the env package that names an optional block (an
  identifier or a string that is the block, not a docstring) is at most three files, the declaration
  (``core/layout.py``), the kernel (``core/observation.py``) and the option (``config.py``).
"""

from __future__ import annotations

import ast
import math
import re
from pathlib import Path

import numpy as np

from planetnav_env.batch import BatchCore
from planetnav_env.config import EnvConfig
from planetnav_env.core import layout as L
from planetnav_env.envs.registration import id_options
from planetnav_env.numerics.portable_math import log1p

PACKAGE = Path(__file__).resolve().parents[2] / "planetnav_env"
_LOG_SCALE = math.log1p(L.SINCE_SCALE_STEPS)


# --- numpy oracles of the history blocks ---
def _scaled(count: np.ndarray) -> np.ndarray:
    return np.minimum(log1p(count) / _LOG_SCALE, 1.0)


class _Oracle:
    """The blocks of N rows from their counts, advanced with numpy from each step's outcome."""

    def __init__(self, cfg: EnvConfig, n: int) -> None:
        self.n_p, self.n_t = cfg.n_planets, cfg.n_targets
        dof = 3.0 if cfg.measurement_model.endswith("+size") else 2.0
        self.dof = np.array([dof] * cfg.n_planets + [1.0] * cfg.n_pulsars)
        self.since = np.full((n, self.n_t), np.inf)
        self.images = np.zeros((n, self.n_p))
        self.fixes = np.zeros((n, self.n_p))
        self.res_n = np.zeros((n, self.n_t))
        self.res_sum = np.zeros((n, self.n_t))

    def clear(self, rows: np.ndarray) -> None:
        self.since[rows] = np.inf
        for a in (self.images, self.fixes, self.res_n, self.res_sum):
            a[rows] = 0.0

    def count(self, core: BatchCore, rows: np.ndarray) -> None:
        i, f = core.i, core.f
        for r in rows:
            t = int(i[r, L.I_TARGET])
            self.since[r] += 1.0
            if i[r, L.I_MEASURED] and 0 <= t < self.n_t:
                self.since[r, t] = 0.0
            if 0 <= t < self.n_p:
                camera = i[r, L.I_SENSOR] == L.SENSOR_CAMERA
                failed = i[r, L.I_REASON] == L.REASON_IMAGE_FAILED
                self.images[r, t] += float(camera) + float(failed)
                self.fixes[r, t] += float(camera)
            if i[r, L.I_SENSOR] != L.SENSOR_NONE and 0 <= t < self.n_t:
                nis = f[r, L.F_NIS] / self.dof[t]
                if np.isfinite(nis):
                    self.res_n[r, t] += 1.0
                    self.res_sum[r, t] += nis

    def blocks(self, p: np.ndarray) -> dict[str, np.ndarray]:
        since = np.where(
            np.isfinite(self.since), _scaled(np.where(np.isfinite(self.since), self.since, 0)), 1.0
        )
        image = np.concatenate([(self.fixes + 1.0) / (self.images + 2.0), _scaled(self.images)], axis=1)
        mean = (self.res_sum + 2.0) / (self.res_n + 2.0)
        sigma = np.sqrt(np.stack([p[:, 0, 0], p[:, 1, 1], p[:, 2, 2]], axis=1))
        rho = [p[:, a, b] / (sigma[:, a] * sigma[:, b]) for a, b in ((0, 1), (0, 2), (1, 2))]
        return {
            "since_measured": since.astype(np.float32).astype(float),
            "image_log": image.astype(np.float32).astype(float),
            "residual_log": (np.minimum(mean, L.RESIDUAL_CAP) / L.RESIDUAL_CAP)
            .astype(np.float32)
            .astype(float),
            "position_correlation": np.clip(np.stack(rho, axis=1), -1.0, 1.0),
        }


def _check(core: BatchCore, oracle: _Oracle, when: str) -> None:
    want = oracle.blocks(core.p)
    got = core.layout.to_dict(core.obs)
    for name, values in want.items():
        block = got[name].reshape(core.num_rows, -1)
        assert block.tobytes() == values.tobytes(), f"{name}, {when}"


def test_history_blocks_equal_numpy_oracles_bit_for_bit() -> None:
    # Image failures (image_log), pulsars (residual log with one degree of freedom), every history block.
    cfg = EnvConfig.from_dict(
        {**id_options("planetnav/MarsApproach-Tasking-v2"), "observe_since_measured": True,
         "observe_residual_log": True, "observe_position_correlation": True, "episode_steps": 40,
         "decision_steps": 1}  # core.step: one physics step
    )  # fmt: skip
    n = 4
    core = BatchCore(cfg, n)
    assert all(core.layout.has(b) for b in ("since_measured", "image_log", "residual_log"))
    oracle = _Oracle(cfg, n)
    rows = np.arange(n)
    core.reset_rows(rows, [np.random.default_rng(40 + r) for r in rows])
    oracle.clear(rows)
    oracle.count(core, rows)
    _check(core, oracle, "reset")
    rng = np.random.default_rng(0)
    targets = rng.integers(-1, cfg.n_targets, n)
    seen = {"fix": 0, "failed": 0, "xray": 0}
    for k in range(60):
        if k % 6 == 0:  # held long enough for a pulsar's integration
            targets = rng.integers(-1, cfg.n_targets, n)
        active = rng.random(n) < 0.8
        # The drawn targets as the relative actions that reach them (-1, none: keep the current one).
        current = np.maximum(core.i[:, L.I_TARGET], 0)
        raw = np.where(targets < 0, 0, (targets - current) % cfg.n_targets).astype(float)
        core.step(raw.reshape(n, 1), active)
        stepped = np.flatnonzero(active)
        oracle.count(core, stepped)
        seen["fix"] += int((core.i[stepped, L.I_SENSOR] == L.SENSOR_CAMERA).sum())
        seen["failed"] += int((core.i[stepped, L.I_REASON] == L.REASON_IMAGE_FAILED).sum())
        seen["xray"] += int((core.i[stepped, L.I_SENSOR] == L.SENSOR_XRAY).sum())
        _check(core, oracle, f"step {k}")
        done = np.flatnonzero((core.i[:, L.I_TERMINATED] != 0) | (core.i[:, L.I_TRUNCATED] != 0))
        if done.size:
            core.reset_rows(done, [np.random.default_rng(100 + k + r) for r in done])
            oracle.clear(done)
            oracle.count(core, done)
            _check(core, oracle, f"reset after step {k}")
    assert min(seen.values()) > 0, seen  # the rollout exercised every counting branch


def test_position_correlation_of_any_covariance_equals_numpy() -> None:
    """Covariances spanning the magnitudes a filter reaches [km^2, km^2/s^2]: the kernel's block equals
    numpy's elementwise formula bit for bit (math.sqrt and np.sqrt are both correctly rounded)."""
    cfg = EnvConfig.from_dict(
        {**id_options("planetnav/Cruise-Target-v1"), "observe_position_correlation": True}
    )
    n = 256
    core = BatchCore(cfg, n)
    rows = np.arange(n)
    core.reset_rows(rows, [np.random.default_rng(r) for r in rows])
    rng = np.random.default_rng(5)
    a = rng.standard_normal((n, 6, 6)) * 10.0 ** rng.uniform(-1, 4, (n, 1, 1))
    core.p[:] = a @ a.transpose(0, 2, 1)
    core.step(np.zeros((n, 1)))  # observed after the step, from its covariance
    want = _Oracle(cfg, n).blocks(core.p)["position_correlation"]
    assert core.layout.to_dict(core.obs)["position_correlation"].tobytes() == want.tobytes()


# --- one declaration per block ---
def _code_names(tree: ast.AST) -> set[str]:
    """Identifiers of a module's code and the identifiers its string constants hold, docstrings left out."""
    docstrings = {
        id(node.body[0].value)
        for node in ast.walk(tree)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
        and node.body
        and isinstance(node.body[0], ast.Expr)
        and isinstance(node.body[0].value, ast.Constant)
    }
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            names.add(node.id)
        elif isinstance(node, ast.Attribute):
            names.add(node.attr)
        elif isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            names.add(node.name)
        elif isinstance(node, ast.arg):
            names.add(node.arg)
        elif isinstance(node, ast.keyword) and node.arg:
            names.add(node.arg)
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docstrings:
            # A string names a block as data when it is an identifier ("momentum", "OB_MOMENTUM"), or holds
            # one with an underscore ("observe_momentum=..."); prose ("momentum dumps by thrusters") does not.
            if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", node.value):
                names.add(node.value)
            else:
                names.update(w for w in re.findall(r"[A-Za-z_][A-Za-z0-9_]*", node.value) if "_" in w)
    return names


def test_an_observation_block_is_named_in_at_most_three_product_files() -> None:
    """Adding a block touches its declaration, its kernel and its option: no other module of the env
    package names it (spaces, decoding, offsets, the device env and the kernels' parameters all read the
    declaration). A task that switches a block on names it as data (its declaration's ``Layout.blocks``,
    or the option ``observe_<name>``), which is not the block's plumbing: the task families' modules are
    not counted (``tasks/spec.py``, the records they fill, is)."""
    families = {p.name for p in (PACKAGE / "tasks").glob("*.py")} - {"__init__.py", "spec.py", "describe.py"}
    assert families, "no task family modules found (the scan is broken)"
    modules = {
        p.relative_to(PACKAGE).as_posix(): _code_names(ast.parse(p.read_text()))
        for p in PACKAGE.rglob("*.py")
        if not (p.parent.name == "tasks" and p.name in families)
    }
    assert len(modules) > 50
    for block in L.OBSERVATION_BLOCKS:
        name = block.name
        pattern = re.compile(rf"^_?(count_)?{name}(_start)?$|^OB_{name.upper()}$")
        files = sorted(path for path, names in modules.items() if any(pattern.match(s) for s in names))
        assert files, f"{name}: no module names it (the scan is broken)"
        allowed = {"core/layout.py", "core/observation.py", "config.py"}
        if name == "since_measured":  # also part of the decision interface, which tasks/spec.py declares
            allowed |= {"tasks/spec.py"}
        assert set(files) <= allowed and len(files) <= len(allowed), f"{name} is named in {files}"
        assert "core/observation.py" in files, f"{name}: no kernel writes it"
        assert block.option in EnvConfig.__dataclass_fields__, f"{name}: no option {block.option}"
