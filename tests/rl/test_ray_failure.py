"""Losing a worker node mid-sweep: the sweep finishes, the lost trials are retried or reported as failed,
and nothing already finished is lost (its own two-node loopback cluster, set up as in
``tests/rl/test_ray.py``, so that removing a node disturbs no other test). An interrupted sweep resumes.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

# Ray reads this once, at import: keep every Ray address on 127.0.0.1 (planetnav_rl.cluster explains).
os.environ["RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"] = "0"
ray = pytest.importorskip("ray")

from ray.tune import Callback  # noqa: E402

from planetnav_rl.cluster import loopback_cluster  # noqa: E402
from planetnav_rl.tune import load_sweep, run_sweep  # noqa: E402

pytestmark = pytest.mark.ray

ROOT = Path(__file__).resolve().parents[2]
CONFIGS = ROOT / "configs"


#: What the callback sees and does; module state, because Tune pickles its callbacks with the experiment.
_STATE: dict[str, Any] = {}


class _RemoveWorkerMidSweep(Callback):
    """Once a trial has finished and another reports from the worker node without having finished, remove
    the worker node (from a thread: Tune's loop must keep running). Records what had finished by then."""

    def on_trial_complete(self, iteration: int, trials: list, trial: Any, **info: Any) -> None:
        if not _STATE["removed"].is_set() and trial.last_result:
            _STATE["finished"][trial.trial_id] = trial.last_result["mean_pos_err_km"]

    def on_trial_result(self, iteration: int, trials: list, trial: Any, result: dict, **info: Any) -> None:
        worker = _STATE["worker"].node_id
        if _STATE["thread"] is not None or not _STATE["finished"] or result.get("node_id") != worker:
            return
        if result["training_iteration"] >= _STATE["iterations"]:
            return  # its last report: it is finishing, not mid-run
        _STATE["victims"] = {trial.trial_id} | {
            t.trial_id
            for t in trials
            if t.status == "RUNNING" and (t.last_result or {}).get("node_id") == worker
        }
        _STATE["thread"] = threading.Thread(target=_remove, daemon=True)
        _STATE["thread"].start()


def _remove() -> None:
    _STATE["cluster"].remove_node(_STATE["worker"])
    _STATE["removed"].set()


def test_sweep_survives_losing_a_worker_node(tmp_path: Path) -> None:
    cluster = loopback_cluster(num_nodes=2, cpus_per_node=1)
    try:
        worker = next(n for n in cluster.worker_nodes)
        sc = load_sweep(CONFIGS / "sweep_smoke.yaml")
        # No early stopping and 3 chunks: every trial runs long enough to be caught mid-run.
        sc = dataclasses.replace(sc, scheduler={"type": "none"}, iterations=3, max_failures=2)
        sc.base_config = {**sc.base_config, "n_timesteps": 384}
        _STATE.update(
            cluster=cluster,
            worker=worker,
            iterations=sc.iterations,
            finished={},
            victims=set(),
            removed=threading.Event(),
            thread=None,
        )
        summary = run_sweep(sc, tmp_path / "sweep", callbacks=[_RemoveWorkerMidSweep()])
        assert _STATE["removed"].is_set(), "the worker node was never removed mid-trial"
        assert _STATE["victims"]
        rows = {r["trial"]: r for r in summary["rows"]}
        assert len(rows) == 4  # the sweep finished: every trial accounted for
        # Nothing finished before the failure is lost: same status and metric as when it finished.
        for tid, metric in _STATE["finished"].items():
            assert rows[tid]["status"] == "TERMINATED" and rows[tid][sc.metric] == metric
        # The interrupted trial(s) were retried on the surviving node from their checkpoint, or reported.
        head, lost = cluster.head_node.node_id[:12], _STATE["worker"].node_id[:12]
        for tid in _STATE["victims"]:
            r = rows[tid]
            assert r["nodes_seen"].split()[0] == lost, r
            if r["status"] == "TERMINATED":  # retried: finished on the surviving node, all its iterations
                assert r["node_id"] == head and r["nodes_seen"].split() == [lost, head], r
                assert r["iterations"] == sc.iterations, r
            else:
                assert r["status"] == "ERROR" and r["error"], r
        assert all(r["status"] in ("TERMINATED", "ERROR") for r in rows.values())
        assert (tmp_path / "sweep" / "results.csv").is_file()
    finally:
        ray.shutdown()
        cluster.shutdown()
        _STATE.clear()


def _finished_trials(exp_dir: Path, iterations: int) -> dict[str, float]:
    """Trials whose result.json already holds their last iteration: trial id -> metric."""
    out = {}
    for f in exp_dir.glob("*/result.json"):
        lines = [json.loads(x) for x in f.read_text().splitlines() if x.strip()]
        if lines and lines[-1]["training_iteration"] >= iterations:
            out[lines[-1]["trial_id"]] = lines[-1]["mean_pos_err_km"]
    return out


def test_interrupted_sweep_resumes(tmp_path: Path) -> None:
    """Ctrl-C (SIGINT) after the first trial finished, then ``--resume``: every trial completes and the one
    finished before the interruption is kept as it was, not run again."""
    sweep = yaml.safe_load((CONFIGS / "sweep_smoke.yaml").read_text())
    sweep.update(base=str(CONFIGS / "smoke.yaml"), scheduler={"type": "none"}, iterations=2)
    cfg = tmp_path / "sweep.yaml"
    cfg.write_text(yaml.safe_dump(sweep))
    run_dir = tmp_path / "run"
    cmd = [sys.executable, str(ROOT / "train.py"), "tune", "--config", str(cfg), "--run-dir", str(run_dir)]
    env = {**os.environ, "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER": "0"}
    # One CPU: trials run one after another, so the interruption falls between the first and the last.
    proc = subprocess.Popen([*cmd, "--num-cpus", "1"], cwd=ROOT, env=env)
    try:
        deadline = time.monotonic() + 900
        while not (finished := _finished_trials(run_dir / "tune", 2)):
            assert proc.poll() is None, "the sweep ended before it could be interrupted"
            assert time.monotonic() < deadline, "no trial finished within 900 s"
            time.sleep(0.5)
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=120)
    finally:
        if proc.poll() is None:
            proc.kill()
    before = _finished_trials(run_dir / "tune", 2)
    assert len(before) < 4, "every trial had finished: nothing was interrupted"
    assert finished.items() <= before.items()
    subprocess.run([*cmd, "--resume", "--num-cpus", "2"], cwd=ROOT, env=env, check=True, timeout=900)
    with open(run_dir / "results.csv") as fh:
        rows = {r["trial"]: r for r in csv.DictReader(fh)}
    assert len(rows) == 4 and all(r["status"] == "TERMINATED" for r in rows.values()), rows
    for tid, metric in before.items():  # kept, not retrained: the same metric to the last digit
        assert float(rows[tid]["mean_pos_err_km"]) == metric
    assert (run_dir / "best_config.yaml").is_file()
