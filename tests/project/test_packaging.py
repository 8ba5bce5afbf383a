"""Packaging: what `pip install .` installs (packages, data, entry points) and that the package list
matches the tree."""

from __future__ import annotations

import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _declared() -> tuple[list[str], dict[str, str]]:
    tool = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
    return tool["packages"], tool["package-dir"]


def test_every_package_folder_is_declared() -> None:
    """The explicit package list (needed for the agents -> planetnav_agents mapping) misses no folder."""
    packages, package_dir = _declared()
    folder_of = {name: folder for name, folder in package_dir.items()}
    # every folder of a package that holds files: the code packages and the data-only ones (setuptools
    # warns about a data folder that is not declared as a package)
    roots = {folder_of.get(p, p) for p in packages if "." not in p}
    on_disk = set()
    for root in roots:
        for folder in [ROOT / root, *(ROOT / root).rglob("*")]:
            if not folder.is_dir() or folder.name == "__pycache__":
                continue
            if any(f.is_file() for f in folder.iterdir()):
                on_disk.add(".".join(folder.relative_to(ROOT).parts))
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
    assert "planetnav_agents" in tops and "planetnav_env" in tops and "planetnav_validation" in tops
    assert "agents" not in tops, sorted(tops)
    names = zipfile.ZipFile(wheel).namelist()
    assert "planetnav_agents/greedy.py" in names
    # the shipped suite baselines (planetnav_train.shipped loads suite:<task> from the installed package)
    assert "planetnav_train/baselines/manifest.json" in names
    assert "planetnav_train/suite/runner.py" in names
    # setuptools >= 77 ships LICEN[CS]E* by default (PEP 639): the declared license's text
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names), names
    entry_points = next(n for n in names if n.endswith(".dist-info/entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(entry_points).decode()
    assert "planetnav_train.loaders:register" in text and "planetnav_rl.extensions:register" in text


def test_wheel_build_warns_of_no_undeclared_package(tmp_path: Path) -> None:
    """setuptools names a folder with files that the package list misses ("... is absent from the
    `packages` configuration")."""
    out = subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-v", "-w", str(tmp_path),
         str(ROOT)],
        check=True,
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert "absent from the `packages`" not in out.stdout + out.stderr


def test_tests_mirror_the_packages() -> None:
    """One test folder per package (env, agents, train, rl, validation) plus project checks; none loose."""
    tests = ROOT / "tests"
    assert not sorted(p.name for p in tests.glob("test_*.py"))
    folders = {p.name for p in tests.iterdir() if p.is_dir() and any(p.glob("test_*.py"))}
    assert folders == {"env", "agents", "train", "rl", "validation", "project"}
