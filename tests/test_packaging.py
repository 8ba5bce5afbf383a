"""Packaging: what `pip install .` installs, and the checkout's deprecated `agents` alias."""

from __future__ import annotations

import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _declared() -> tuple[list[str], dict[str, str]]:
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    return tool["packages"], tool["package-dir"]


def test_every_package_folder_is_declared() -> None:
    """The explicit package list (needed for the agents -> planetnav_agents mapping) misses no folder."""
    packages, package_dir = _declared()
    folder_of = {name: folder for name, folder in package_dir.items()}
    on_disk = set()
    for init in ROOT.glob("*/**/__init__.py"):
        rel = init.parent.relative_to(ROOT)
        if rel.parts[0] in {"tests", "build"} or rel.parts[0].startswith("."):
            continue
        on_disk.add(".".join(rel.parts))
    declared = {
        ".".join([folder_of.get(p.split(".")[0], p.split(".")[0]), *p.split(".")[1:]]) for p in packages
    }
    assert declared == on_disk, f"declared only: {declared - on_disk}; on disk only: {on_disk - declared}"
    assert "agents" not in packages and package_dir.get("planetnav_agents") == "agents"


def test_wheel_installs_planetnav_agents_and_no_top_level_agents(tmp_path: Path) -> None:
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
            str(ROOT),
        ],
        check=True,
        capture_output=True,
    )
    (wheel,) = tmp_path.glob("planetnav-*.whl")
    tops = {name.split("/")[0] for name in zipfile.ZipFile(wheel).namelist()}
    assert "planetnav_agents" in tops and "planetnav_env" in tops
    assert "agents" not in tops, sorted(tops)
    names = zipfile.ZipFile(wheel).namelist()
    assert "planetnav_agents/greedy.py" in names
    # the shipped suite baselines' manifest (agents/shipped.py loads suite:<task> from the installed package)
    assert "planetnav_agents/baselines/manifest.json" in names


def test_checkout_import_agents_warns_and_is_planetnav_agents() -> None:
    code = (
        "import warnings; warnings.simplefilter('error', DeprecationWarning)\n"
        "try:\n    import agents\nexcept DeprecationWarning as e:\n    print('warned:', e)\n"
        "warnings.simplefilter('ignore')\n"
        "import agents, agents.greedy, planetnav_agents, planetnav_agents.greedy\n"
        "assert agents is planetnav_agents and agents.greedy is planetnav_agents.greedy\n"
        "print('aliased')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert "warned:" in out.stdout and "planetnav_agents" in out.stdout
    assert "aliased" in out.stdout


def test_checkout_alias_refuses_when_another_distribution_owns_agents(monkeypatch) -> None:
    from planetnav_agents import _checkout_alias

    monkeypatch.setattr(
        _checkout_alias.importlib.metadata,
        "packages_distributions",
        lambda: {"agents": ["openai-agents", "planetnav"]},
    )
    assert _checkout_alias.other_agents_distributions() == ["openai-agents"]
    with pytest.raises(ImportError, match="openai-agents"):
        _checkout_alias.alias_checkout_import()
