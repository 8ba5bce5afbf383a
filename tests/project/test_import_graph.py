"""The project's import graph: packages depend one way, no module cycle, and nothing imports train.py.

Read from the source with ``ast`` (nothing is imported): every ``import`` and ``from ... import``
anywhere in a module counts, including those inside functions, since a lazy import still ties the two
modules together. The folder ``agents/`` is the package ``planetnav_agents``. The packages are layered
``planetnav_env <- planetnav_agents <- planetnav_train <- planetnav_rl``: each imports only those on its
left (:data:`ALLOWED`); the packages above the environment meet through registries filled from entry
points (``pyproject.toml``), not imports. ``planetnav_validation`` (reproductions, harnesses, oracles)
imports only ``planetnav_env``, and no product package imports it. No package imports a top-level
``research`` package.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
#: package name -> folder
PACKAGES = {
    "planetnav_env": "planetnav_env",
    "planetnav_agents": "agents",
    "planetnav_rl": "planetnav_rl",
    "planetnav_train": "planetnav_train",
    "planetnav_validation": "planetnav_validation",
}
#: package -> the project packages it may import (itself aside)
ALLOWED = {
    "planetnav_env": set(),
    "planetnav_agents": {"planetnav_env"},
    "planetnav_train": {"planetnav_env", "planetnav_agents"},
    "planetnav_rl": {"planetnav_env", "planetnav_agents", "planetnav_train"},
    # the reproductions, harnesses and test oracles: over the environment's physics, beside the product
    "planetnav_validation": {"planetnav_env"},
}
#: top-level names no package may import (research scripts live outside the packages)
FORBIDDEN_TOP_LEVEL = {"research", "agents", "train"}


def project_modules() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the installed packages."""
    mods: dict[str, Path] = {}
    for pkg, folder in PACKAGES.items():
        base = ROOT / folder
        if not base.is_dir():
            continue
        for path in base.rglob("*.py"):
            parts = list(path.relative_to(base).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            mods[".".join([pkg, *parts])] = path
    return mods


def _imported_names(path: Path, module: str, is_package: bool) -> set[str]:
    """Every dotted name imported by the file (relative imports resolved); ``from pkg import name`` gives
    ``pkg.name``."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if is_package else module.rpartition(".")[0]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base_parts = package.split(".")
                base_parts = base_parts[: len(base_parts) - (node.level - 1)]
                base = ".".join(base_parts + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            # ``from pkg import name``: the submodule pkg.name if there is one, else pkg itself (the
            # resolver falls back to the longest module prefix)
            out.update(base if alias.name == "*" else f"{base}.{alias.name}" for alias in node.names)
    return out


def import_graph() -> dict[str, set[str]]:
    mods = project_modules()
    graph: dict[str, set[str]] = {}
    for name, path in mods.items():
        targets = set()
        for imported in _imported_names(path, name, path.name == "__init__.py"):
            # the longest project module that the imported name is or lies in
            parts = imported.split(".")
            for k in range(len(parts), 0, -1):
                cand = ".".join(parts[:k])
                if cand in mods:
                    if cand != name:
                        targets.add(cand)
                    break
        graph[name] = targets
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_the_graph_reader_finds_a_planted_cycle() -> None:
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_lazy_imports_are_edges(tmp_path) -> None:
    mod = tmp_path / "m.py"
    mod.write_text(
        "import os\n"
        "def __getattr__(name):\n    from planetnav_env.envs import env\n    return env\n"
        "def f():\n    from planetnav_env import config\n"
    )
    names = _imported_names(mod, "m", False)
    assert names == {"os", "planetnav_env.envs.env", "planetnav_env.config"}


def test_the_graph_reader_sees_known_edges() -> None:
    graph = import_graph()
    assert "planetnav_env.batch" in graph["planetnav_env.envs.env"]
    assert "planetnav_env.config" in graph["planetnav_env.batch"]
    assert "planetnav_env.core.kernels" in graph["planetnav_env.batch"]


def test_project_import_graph_has_no_cycle() -> None:
    found = cycles(import_graph())
    assert not found, "import cycles: " + "; ".join(" <-> ".join(c) for c in found)


def test_nothing_imports_train_py() -> None:
    """train.py is a command line over planetnav_train; no module, test or benchmark imports it."""
    offenders = []
    for path in ROOT.rglob("*.py"):
        rel = path.relative_to(ROOT)
        if rel.parts[0].startswith(".") or rel.parts[0] in {"build", "runs", "results"}:
            continue
        if path == Path(__file__).resolve():
            continue  # this file names what it looks for
        text = path.read_text()
        tree = ast.parse(text, filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import) and any(a.name == "train" for a in node.names):
                offenders.append(str(rel))
            elif isinstance(node, ast.ImportFrom) and node.module == "train" and not node.level:
                offenders.append(str(rel))
        if "train.py" in text and ("spec_from_file_location" in text or "sys.path.insert" in text):
            offenders.append(f"{rel} (loads train.py by path)")
    assert not offenders, offenders


def _all_imports() -> dict[str, set[str]]:
    """Module -> every dotted name it imports (project or not)."""
    return {
        name: _imported_names(path, name, path.name == "__init__.py")
        for name, path in project_modules().items()
    }


def test_the_layer_check_sees_a_planted_upward_import() -> None:
    assert _layer_violations({"planetnav_agents.x": {"planetnav_train.sb3", "numpy"}}) == [
        "planetnav_agents.x imports planetnav_train.sb3"
    ]
    assert _layer_violations({"planetnav_rl.x": {"planetnav_train.sb3"}}) == []
    assert _layer_violations({"planetnav_env.x": {"planetnav_validation.numpy_ekf"}}) == [
        "planetnav_env.x imports planetnav_validation.numpy_ekf"
    ]
    assert _layer_violations({"planetnav_validation.x": {"planetnav_env.core"}}) == []


def _layer_violations(imports: dict[str, set[str]]) -> list[str]:
    out = []
    for module, names in sorted(imports.items()):
        pkg = module.split(".")[0]
        for name in sorted(names):
            top = name.split(".")[0]
            if top in ALLOWED and top != pkg and top not in ALLOWED[pkg]:
                out.append(f"{module} imports {name}")
            elif top in FORBIDDEN_TOP_LEVEL:
                out.append(f"{module} imports the top-level {top!r}")
    return out


def test_packages_depend_one_way() -> None:
    """env <- agents <- train <- rl, lazy imports included; no package imports ``research``."""
    found = _layer_violations(_all_imports())
    assert not found, found


def test_no_module_level_getattr_aliases() -> None:
    """No module resolves names lazily through a module-level ``__getattr__`` (an alias of an old path)."""
    offenders = []
    for name, path in project_modules().items():
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in tree.body:
            targets = [t.id for t in getattr(node, "targets", []) if isinstance(t, ast.Name)]
            if (isinstance(node, ast.FunctionDef) and node.name == "__getattr__") or "__getattr__" in targets:
                offenders.append(name)
    assert not offenders, offenders


def _docstring_nodes(tree: ast.AST) -> set[int]:
    """The ids of the docstrings' nodes of a module and of its classes and functions."""
    out: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
                out.add(id(body[0].value))
    return out


def test_the_product_does_not_use_research() -> None:
    """research/ (experiments, probes, commit-pair tools) may use the packages; the packages and train.py
    never import research code nor open a file under research/ (docstrings may cite it)."""
    offenders = []
    paths = [ROOT / "train.py", *(p for folder in PACKAGES.values() for p in (ROOT / folder).rglob("*.py"))]
    for path in paths:
        tree = ast.parse(path.read_text(), filename=str(path))
        docs = _docstring_nodes(tree)
        rel = path.relative_to(ROOT)
        for node in ast.walk(tree):
            if isinstance(node, ast.Import) and any(a.name.split(".")[0] == "research" for a in node.names):
                offenders.append(f"{rel}: imports research")
            elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "research":
                offenders.append(f"{rel}: imports from research")
            elif (
                isinstance(node, ast.Constant)
                and isinstance(node.value, str)
                and id(node) not in docs
                and ("research/" in node.value or node.value == "research")
            ):
                offenders.append(f"{rel}: the string {node.value!r}")
    assert not offenders, offenders
