"""CI's second pass (``make test-ray``, under the [ray] extra's gymnasium) leaves out only tests that cannot
differ there: the Makefile's ``RAY_SAME`` lists environment tests that reach neither gymnasium nor the
environment classes, through any module they import (read with ``ast``, lazy imports included).

Importing any ``planetnav_env`` module runs the package's ``__init__``, which registers the ids with
gymnasium; that registers names and computes nothing, so it is not followed here.
"""

from __future__ import annotations

import re
from pathlib import Path

from test_import_graph import _imported_names, import_graph, project_modules

ROOT = Path(__file__).resolve().parents[2]
#: What the [ray] environment holds in another version than .venv, or that only the training side uses.
DIFFERS = ("gymnasium", "ray", "torch", "torchrl", "tensordict", "stable_baselines3", "sb3_contrib")
#: Project modules that wrap the environment in Gymnasium's API or train on it.
GYM_SIDE = ("planetnav_env.envs", "planetnav_agents", "planetnav_train", "planetnav_rl")


def ray_same() -> list[Path]:
    text = (ROOT / "Makefile").read_text().replace("\\\n", " ")
    match = re.search(r"^RAY_SAME\s*:=(.*)$", text, re.M)
    assert match, "no RAY_SAME in the Makefile"
    return [ROOT / "tests" / "env" / f"test_{name}.py" for name in match.group(1).split()]


def reached(path: Path) -> set[str]:
    """Every module name the test file imports, and every one the project modules among them import in
    turn (project modules by their longest matching name, others as written)."""
    mods = project_modules()
    graph = import_graph()

    def project_module(name: str) -> str | None:
        parts = name.split(".")
        for k in range(len(parts), 0, -1):
            if ".".join(parts[:k]) in mods:
                return ".".join(parts[:k])
        return None

    seen: set[str] = set()
    todo = list(_imported_names(path, path.stem, False))
    while todo:
        name = todo.pop()
        if name in seen:
            continue
        seen.add(name)
        mod = project_module(name)
        if mod is not None and mod not in seen:
            seen.add(mod)
            todo += graph[mod]
            todo += _imported_names(mods[mod], mod, mods[mod].name == "__init__.py")
    return seen


def _offending(names: set[str]) -> list[str]:
    return sorted(
        n
        for n in names
        if n.split(".")[0] in DIFFERS or any(n == g or n.startswith(g + ".") for g in GYM_SIDE)
    )


def test_tests_left_out_of_the_ray_pass_never_reach_gymnasium() -> None:
    files = ray_same()
    assert files
    for path in files:
        assert path.is_file(), f"RAY_SAME names {path.name}, which is not there"
        bad = _offending(reached(path))
        assert not bad, f"{path.name} reaches {bad[:5]}: it can differ under the [ray] gymnasium"


def test_the_check_sees_a_test_that_reaches_the_environment() -> None:
    assert _offending(reached(ROOT / "tests" / "env" / "test_golden.py"))
    assert _offending(reached(ROOT / "tests" / "env" / "test_fast_ekf.py"))  # a lazy import of the env


def test_the_validation_tests_never_reach_gymnasium() -> None:
    """tests/validation is not in the [ray] pass's list (RAY_TESTS): like RAY_SAME, it cannot differ there."""
    files = sorted((ROOT / "tests" / "validation").glob("test_*.py"))
    assert files
    for path in files:
        bad = _offending(reached(path))
        assert not bad, f"{path.name} reaches {bad[:5]}: add tests/validation to the Makefile's RAY_TESTS"
