"""Publishing a benchmark suite's results into the repository (docs/suite.md "Publishing"):

- :func:`publish_json`: the aggregated JSON (``OUT/suite.json``: protocol, tasks, references, every run,
  aggregates), without the runs' per-seed arrays, to a tracked path, ``docs/benchmark.json`` (``runs/``
  is not in the repository; :mod:`planetnav_train.suite.restore` writes the records back from it);
- :func:`update_readme`: the summary tables (:func:`planetnav_train.suite.leaderboard.summary_markdown`)
  written between the README's ``<!-- suite-summary:start -->`` and ``<!-- suite-summary:end -->``
  markers;
- :func:`ship_baselines`: the page's ranked best policy of each task (:func:`best_raw_runs`) copied to
  ``planetnav_train/baselines/<task>.zip`` with its manifest entry, loadable as the agent ``suite:<task>``
  (:mod:`planetnav_train.shipped`);
  a model of 1 MB or more ships as its policy-only export (``<task>.policy.zip``,
  :func:`planetnav_train.export.export_policy`) when that is under 1 MB, and is refused otherwise.

``train.py suite-publish`` re-aggregates every record of an output folder without training anything, then
does whichever of the three its flags ask; ``train.py suite`` takes ``--publish-json`` and ``--readme``
too.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from planetnav_env.errors import ConfigError
from planetnav_train.config import is_rllib_algo
from planetnav_train.export import export_policy
from planetnav_train.provenance import git_state
from planetnav_train.sb3 import resolve_model_path
from planetnav_train.shipped import (
    BASELINES_DIR,
    MANIFEST_NAME,
    MAX_BASELINE_BYTES,
    file_sha256,
    load_manifest,
)
from planetnav_train.suite.cells import Cell
from planetnav_train.suite.leaderboard import summary_markdown
from planetnav_train.suite.runner import load_records, write_json_atomic
from planetnav_train.suite.scoring import best_ranked, entry_name, iqm, is_ranked
from planetnav_train.suite.tasks import get_task, records_version

#: The README's summary block lies between these two lines (the text between them is replaced).
README_START = "<!-- suite-summary:start -->"
README_END = "<!-- suite-summary:end -->"


def check_tree(allow_dirty: bool = False, source_dir: str | Path | None = None) -> dict[str, Any]:
    """The git state (:func:`planetnav_train.provenance.git_state`) of the planetnav source that publishes,
    when it is a clean checkout at a commit: published tables are aggregated there, and the page names the
    commit. Otherwise (uncommitted changes, or no git checkout) :class:`ConfigError` naming what differs,
    unless ``allow_dirty`` (``--allow-dirty``), when the state is returned and the page says so
    (:func:`planetnav_train.suite.leaderboard.provenance_lines`)."""
    state = git_state(source_dir)
    if state["git_commit"] is None:
        problem = "the planetnav source is not a git checkout (there is no commit to name)"
    elif state["git_dirty"]:
        changes = [c.strip() for c in state["git_changes"] or []]
        listed = "; ".join(changes[:5]) + ("; ..." if len(changes) > 5 else "")
        problem = f"the working tree at {state['git_commit'][:12]} has uncommitted changes ({listed})"
    else:
        return state
    if not allow_dirty:
        raise ConfigError(
            f"refusing to publish: {problem}. Commit, then publish from the clean tree (the page names its "
            "commit), or pass --allow-dirty (the page then says the tree was not clean)"
        )
    return state


def load_suite_json(path: str | Path) -> dict[str, Any]:
    """A suite JSON (``OUT/suite.json`` or a published copy); :class:`ConfigError` naming a missing file."""
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"no suite JSON at {p}: run `train.py suite` (or `suite-publish`) first")
    return json.loads(p.read_text())


def _copy_atomic(src: Path, dest: Path) -> None:
    """Copy so that an interrupted copy leaves the old file or the new one, never half of one."""
    dest.parent.mkdir(parents=True, exist_ok=True)
    tmp = dest.with_name(dest.name + f".tmp{os.getpid()}")
    shutil.copyfile(src, tmp)
    os.replace(tmp, dest)


#: The runs' per-seed arrays and full configurations: in ``OUT/suite.json`` (which the suite command
#: writes), left out of the published copy, whose every figure they only repeat per seed.
_BULKY = ("per_episode", "config")


def compact_suite_json(data: Mapping[str, Any]) -> dict[str, Any]:
    """The suite JSON without its runs' per-seed arrays and configurations (:data:`_BULKY`): every mean,
    interval, score, learning curve, aggregate and command is kept, and the references whole (their
    per-seed values are what :func:`planetnav_train.suite.restore.restore` caches, so that a re-run cell
    in a restored folder does not evaluate the references again)."""

    def strip(v: Any) -> Any:
        if isinstance(v, Mapping):
            return {k: strip(x) for k, x in v.items() if k not in _BULKY}
        if isinstance(v, list):
            return [strip(x) for x in v]
        return v

    return {**data, "runs": strip(list(data.get("runs", [])))}


def publish_json(suite_json_path: str | Path, dest: str | Path) -> Path:
    """Write the aggregated suite JSON, compacted (:func:`compact_suite_json`), to ``dest`` (a tracked path,
    e.g. ``docs/benchmark.json``); the full one stays in the suite's output folder."""
    src = Path(suite_json_path)
    data = load_suite_json(src)  # a missing or unreadable JSON fails here, before anything is replaced
    write_json_atomic(Path(dest), compact_suite_json(data))
    return Path(dest)


def replace_block(text: str, block: str, where: str = "README") -> str:
    """``text`` with the lines between :data:`README_START` and :data:`README_END` replaced by ``block``.
    Raises :class:`ConfigError` naming ``where`` unless each marker occurs once, start before end."""
    starts, ends = text.count(README_START), text.count(README_END)
    if starts != 1 or ends != 1:
        raise ConfigError(
            f"{where}: expected one {README_START!r} and one {README_END!r} line, found {starts} and {ends}"
        )
    head, rest = text.split(README_START)
    if README_END not in rest:
        raise ConfigError(f"{where}: {README_END!r} comes before {README_START!r}")
    tail = rest.split(README_END)[1]
    return f"{head}{README_START}\n{block.rstrip()}\n{README_END}{tail}"


def update_readme(readme: str | Path, data: Mapping[str, Any]) -> Path:
    """Write the summary of suite JSON ``data`` into the README's summary block (the rest untouched)."""
    p = Path(readme)
    if not p.is_file():
        raise ConfigError(f"--readme {p}: no such file")
    p.write_text(replace_block(p.read_text(), summary_markdown(data), str(p)))
    return p


def best_raw_runs(
    records: Sequence[Mapping[str, Any]], tasks: Sequence[str] | None = None, official_only: bool = True
) -> dict[str, Mapping[str, Any]]:
    """Per task, the run to ship: of the page's best entry (:func:`~planetnav_train.suite.scoring.best_ranked`
    over the raw-track candidates: the ranked entry with the highest IQM of the normalized score, ties by
    name), its run with the lowest objective (ties by seed). An unranked entry (a short budget,
    :func:`~planetnav_train.suite.scoring.entry_name`) is never a candidate, whatever its objective.
    ``tasks`` (default: every task with candidate runs) must each have one. ``official_only``: runs with
    smoke settings (``official: false``) are not candidates.

    Raises :class:`ConfigError` naming a task without candidate runs, and what it does have."""
    raw = [r for r in records if r["track"] == "raw"]
    pool = [r for r in raw if r.get("official", False) or not official_only]
    unranked = [r for r in pool if not is_ranked(entry_name(r))]
    pool = [r for r in pool if is_ranked(entry_name(r))]
    wanted = [get_task(t).id for t in tasks] if tasks else sorted({r["task"] for r in pool})
    if not wanted:
        if unranked:
            raise ConfigError(
                f"no raw-track run to ship: the {len(unranked)} candidate run(s) are all unranked "
                f"({', '.join(sorted({entry_name(r) for r in unranked}))}); an unranked entry never ships"
            )
        raise ConfigError(
            f"no raw-track run to ship ({len(raw)} raw-track records, none official; smoke runs ship only "
            "with --allow-smoke)"
            if raw
            else "no raw-track run to ship: the output folder has no raw-track record"
        )
    best = {}
    for task in wanted:
        runs = [r for r in pool if r["task"] == task]
        if not runs:
            short = sorted({entry_name(r) for r in unranked if r["task"] == task})
            smoke = sum(r["task"] == task for r in raw) - sum(r["task"] == task for r in unranked)
            raise ConfigError(
                f"task {task}: no {'official ' if official_only else ''}raw-track run to ship ({smoke} "
                "raw-track record(s) with smoke settings"
                + (f"; unranked, never shipped: {', '.join(short)})" if short else ")")
            )
        by_entry: dict[str, list[Mapping[str, Any]]] = {}
        for r in runs:
            by_entry.setdefault(entry_name(r), []).append(r)
        # the page's per-task IQM (rliable's, over every seed of the entry)
        scores = {e: {"iqm": iqm(np.array([[r["normalized_score"]] for r in rs]))}
                  for e, rs in by_entry.items()}  # fmt: skip
        entry = best_ranked(scores)
        best[task] = min(by_entry[entry], key=lambda r: (r["objective"], int(r["seed"])))
    return best


def _shippable(task: str, algo: str, model: Path, max_bytes: int, scratch: Path) -> tuple[str, Path]:
    """(form, file) to ship for the best model ``model`` of ``task``: ``("full", model)`` when it is under
    ``max_bytes``, else ``("policy-only", export)`` with its policy-only export written under ``scratch``
    when that is. Raises :class:`ConfigError` naming the task, the algorithm and both sizes when even the
    export is ``max_bytes`` or more."""
    size = model.stat().st_size
    if size < max_bytes:
        return "full", model
    try:
        export = export_policy(model, scratch / f"{task}.policy.zip", algo)
    except ValueError as exc:  # a space, argument or parameter the format cannot hold: named in exc
        raise ConfigError(
            f"task {task}: the best raw-track model {model} ({algo}) is {size:,} bytes, not under the "
            f"shipped limit of {max_bytes:,} bytes, and has no policy-only export: {exc}"
        ) from None
    small = export.stat().st_size
    if small >= max_bytes:
        raise ConfigError(
            f"task {task}: the best raw-track model {model} ({algo}) is {size:,} bytes ({size / 1e6:.2f} MB) "
            f"and its policy-only export {small:,} bytes ({small / 1e6:.2f} MB), neither under the shipped "
            f"limit of {max_bytes:,} bytes"
        )
    return "policy-only", export


def ship_baselines(
    out: str | Path,
    dest: str | Path = BASELINES_DIR,
    tasks: Sequence[str] | None = None,
    official_only: bool = True,
    max_bytes: int = MAX_BASELINE_BYTES,
) -> list[dict[str, Any]]:
    """Ship the page's ranked best model of each task (:func:`best_raw_runs` over ``OUT/runs``) to ``dest``
    and record it in ``dest/manifest.json`` (entries of other tasks kept): a model under ``max_bytes``
    bytes as it is (``dest/<task>.zip``, form ``"full"``), a larger one as its policy-only export
    (``dest/<task>.policy.zip``, form ``"policy-only"``: the acting network alone,
    :func:`planetnav_train.export.export_policy`, which checks it acts as the model does) when that is
    under ``max_bytes``. Every chosen model is checked (and exported) before anything is written: an RLlib
    checkpoint (a folder, not one SB3 model), a missing model, or a model whose export is still
    ``max_bytes`` or more is refused with :class:`ConfigError` naming the cell or task, the algorithm and
    the sizes. A task's file of the other form, named by its old entry, is removed. Returns the new
    manifest entries."""
    out, dest = Path(out), Path(dest)
    best = best_raw_runs(load_records(out), tasks, official_only)
    with tempfile.TemporaryDirectory(prefix="planetnav-ship-") as scratch:
        chosen = []
        for task, r in best.items():
            cell = Cell(r["task"], r["algorithm"], r["track"], int(r["seed"]))
            if is_rllib_algo(r["algorithm"]):
                raise ConfigError(
                    f"task {task}: the best raw-track run {cell.key} is an RLlib checkpoint (a folder), not "
                    "one SB3 model file; only SB3 models ship (pass --baseline-tasks without this task)"
                )
            try:
                model = resolve_model_path(out / "models" / cell.key)
            except FileNotFoundError:
                raise ConfigError(
                    f"task {task}: the best raw-track run {cell.key} has no model at "
                    f"{out / 'models' / cell.key}"
                ) from None
            form, file = _shippable(task, r["algorithm"], model, max_bytes, Path(scratch))
            chosen.append((task, r, cell, model, form, file))
        manifest = load_manifest(dest)
        entries = []
        for task, r, cell, model, form, src in chosen:
            file = f"{task}.zip" if form == "full" else f"{task}.policy.zip"
            _copy_atomic(src, dest / file)
            old = manifest["baselines"].get(task, {}).get("file")
            if old and old != file and Path(old).name == old:  # the other form's file: not left behind
                (dest / old).unlink(missing_ok=True)
            entry = {
                "task": task,
                "env_id": get_task(task).env_id,
                "task_version": r.get("task_version"),
                "suite_version": r.get("suite_version"),
                "algorithm": r["algorithm"],
                "eval_mode": r.get("eval_mode", "argmax"),
                "track": "raw",
                "seed": int(r["seed"]),
                "objective_name": r.get("objective_name"),
                "objective": r["objective"],
                "objective_ci95": r.get("objective_ci95"),
                "normalized_score": r["normalized_score"],
                "reference": r.get("reference"),
                "eval_seed": r.get("eval_seed"),
                "eval_episodes": r.get("eval_episodes"),
                "official": bool(r.get("official", False)),
                "source_cell": cell.key,
                "command": r.get("command"),
                "provenance": r.get("provenance"),  # the run's that trained it (None: not recorded)
                "form": form,
                "file": file,
                "bytes": (dest / file).stat().st_size,
                "sha256": file_sha256(dest / file),
            }
            if form == "policy-only":  # the model it was exported from (not shipped)
                entry["source_bytes"] = model.stat().st_size
                entry["source_sha256"] = file_sha256(model)
            manifest["baselines"][task] = entry
            entries.append(entry)
    if chosen:  # each entry keeps its own version; the manifest's is that of the latest shipped
        manifest["suite_version"] = records_version([r for _, r, *_ in chosen])
    manifest["baselines"] = dict(sorted(manifest["baselines"].items()))
    write_json_atomic(dest / MANIFEST_NAME, manifest)
    return entries


__all__ = [
    "README_END",
    "README_START",
    "best_raw_runs",
    "check_tree",
    "load_suite_json",
    "publish_json",
    "replace_block",
    "ship_baselines",
    "update_readme",
]
