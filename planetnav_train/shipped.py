"""The benchmark suite's shipped baselines: the best raw-track policy of each task, stored in the repository
(``planetnav_train/baselines/``) and loadable by name as ``suite:<task>`` (``suite:Cruise-Target-v0``)
wherever an agent name is accepted (:func:`planetnav_agents.make_agent`, ``train.py compare --agents``, a
config's ``eval.agents``).

The folder holds one file per shipped task, in one of two forms (the entry's ``form``; an entry without
one is ``"full"``): ``<task>.zip``, the Stable-Baselines3 model as trained (``"full"``), or
``<task>.policy.zip``, its policy-only export (``"policy-only"``: the acting network alone, for a model of
1 MB or more, :mod:`planetnav_train.policy_only`). ``manifest.json``:
``{"suite_version": N, "baselines": {task: entry}}``, each entry naming the task and its environment id,
the algorithm, training seed, objective (km) with its 95 % interval, normalized score, the suite cell it
came from, the form, the file's size in bytes and its sha256 (a policy-only entry also the source model's
``source_bytes`` and ``source_sha256``). The manifest is written by
``train.py suite-publish --baselines planetnav_train/baselines``
(:func:`planetnav_train.suite.publish.ship_baselines`), which refuses a model whose shipped form would be
1 MB or more. A shipped policy is a raw-track one: the env's own observation, actions and decision
interface, no features.

This module reads the folder; SB3 (:mod:`planetnav_train.sb3`) is imported when an agent is built.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

#: Agent names of a shipped baseline start with this (then the task id).
SHIPPED_PREFIX = "suite:"
#: The folder of the shipped models and their manifest (read at call time, so tests may point it elsewhere).
BASELINES_DIR = Path(__file__).resolve().parent / "baselines"
MANIFEST_NAME = "manifest.json"
#: Largest model shipped, in bytes (the suite's protocol: "under 1 MB", read as 10^6 bytes, the stricter).
MAX_BASELINE_BYTES = 1_000_000
#: The entry's ``form``: the SB3 model as trained, or its policy-only export.
FORMS = ("full", "policy-only")


def is_shipped_spec(spec: str | Path) -> bool:
    """Whether agent spec ``spec`` names a shipped baseline (``suite:<task>``)."""
    return str(spec).startswith(SHIPPED_PREFIX)


def task_of(spec: str | Path) -> str:
    """The task id of ``suite:<task>`` (a namespaced env id ``suite:planetnav/<task>`` is accepted)."""
    text = str(spec)
    if not is_shipped_spec(text):
        raise ValueError(f"{text!r} is not a shipped baseline name ({SHIPPED_PREFIX}<task>)")
    task = text[len(SHIPPED_PREFIX) :].split("/", 1)[-1]
    if not task:
        raise ValueError(f"{text!r}: no task after {SHIPPED_PREFIX!r} (e.g. suite:Cruise-Target-v0)")
    return task


def load_manifest(directory: str | Path | None = None) -> dict[str, Any]:
    """The manifest of ``directory`` (default :data:`BASELINES_DIR`); an absent manifest is an empty one."""
    path = Path(directory or BASELINES_DIR) / MANIFEST_NAME
    if not path.is_file():
        return {"suite_version": None, "baselines": {}}
    try:
        data = json.loads(path.read_text())
    except ValueError as exc:
        raise ValueError(f"{path}: not valid JSON ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("baselines"), dict):
        raise ValueError(f"{path}: expected an object with a 'baselines' mapping (task -> entry)")
    return data


def file_sha256(path: str | Path) -> str:
    """The sha256 of a file's bytes, as hex."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def shipped_model(task: str, directory: str | Path | None = None) -> tuple[Path, dict[str, Any]]:
    """The model file of task ``task``'s shipped baseline and its manifest entry, checked against the
    manifest's size and sha256.

    Raises ``ValueError`` naming the task and the shipped ones when the task has no baseline, or naming
    both hashes when the file differs from the manifest; ``FileNotFoundError`` naming the missing file.
    """
    directory = Path(directory or BASELINES_DIR)
    shipped = load_manifest(directory)["baselines"]
    if task not in shipped:
        raise ValueError(
            f"no shipped baseline for task {task!r} in {directory / MANIFEST_NAME}; shipped: "
            f"{sorted(shipped) or 'none yet (no published suite run has shipped one)'}"
        )
    entry = shipped[task]
    path = directory / entry["file"]
    if not path.is_file():
        raise FileNotFoundError(f"shipped baseline of {task!r}: the manifest names {path}, which is missing")
    digest = file_sha256(path)
    if digest != entry["sha256"]:
        raise ValueError(
            f"shipped baseline of {task!r}: {path} has sha256 {digest}, the manifest says {entry['sha256']}"
        )
    return path, entry


def form_of(entry: dict[str, Any]) -> str:
    """The ``form`` of manifest entry ``entry`` (:data:`FORMS`; absent: ``"full"``, as written before
    policy-only exports); ``ValueError`` naming an unknown one."""
    form = entry.get("form", "full")
    if form not in FORMS:
        raise ValueError(f"shipped baseline of {entry.get('task')!r}: unknown form {form!r}; known: {FORMS}")
    return form


def make_shipped_agent(spec: str, env: Any = None, **kwargs: Any) -> Any:
    """The :class:`planetnav_train.sb3.SB3Agent` of the shipped baseline named ``spec``
    (``suite:<task>``), with the manifest's algorithm and no features (a raw-track policy,
    in the id's own decision interface) acting in the protocol's evaluation mode (the manifest's
    ``eval_mode``); ``kwargs`` go to :class:`SB3Agent` (``deterministic`` overrides the mode). A
    policy-only baseline's model is its :class:`~planetnav_train.policy_only.PolicyOnlyModel`, which
    acts through the same ``predict`` and ``policy`` as the full model, so evaluation takes the same path.
    """
    from planetnav_train.sb3 import SB3Agent

    path, entry = shipped_model(task_of(spec))
    kwargs.setdefault("algo", entry["algorithm"])
    # The action the suite's protocol scored (its record's eval_mode): sampled for the policy-gradient ones.
    kwargs.setdefault("deterministic", entry.get("eval_mode", "argmax") != "sampled")
    if form_of(entry) == "full":
        agent = SB3Agent(path, env, features=[], **kwargs)
    else:
        from planetnav_train.policy_only import load_policy_only

        model = load_policy_only(path)
        if model.algorithm != entry["algorithm"]:
            raise ValueError(
                f"shipped baseline of {task_of(spec)!r}: {path} holds a {model.algorithm} policy, the "
                f"manifest says {entry['algorithm']}"
            )
        agent = _agent_over(model, path, env, features=[], **kwargs)
    agent.name = str(spec) + ("" if agent.deterministic else ":stochastic")
    return agent


def _agent_over(model: Any, path: Path, env: Any, **kwargs: Any) -> Any:
    """An :class:`~planetnav_train.sb3.SB3Agent` over the already-built ``model`` read from ``path``, so
    the agent's checks (spaces against the env), names and acting are SB3Agent's own, not a copy."""
    from planetnav_train import sb3

    return sb3.SB3Agent(path, env, model=model, **kwargs)


__all__ = [
    "BASELINES_DIR",
    "FORMS",
    "MANIFEST_NAME",
    "MAX_BASELINE_BYTES",
    "SHIPPED_PREFIX",
    "file_sha256",
    "form_of",
    "is_shipped_spec",
    "load_manifest",
    "make_shipped_agent",
    "shipped_model",
    "task_of",
]
