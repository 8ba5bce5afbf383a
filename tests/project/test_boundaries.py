"""Module boundaries the import graph alone does not hold: private names stay home, the core imports down.

Read from the source with ``ast``, lazy imports included (:mod:`test_import_graph`'s reader):

* no product module imports an underscore name (``from pkg.mod import _name``) of another top-level
  package, nor of another module of its own package; what one module needs of another is public there;
* the compiled core (``planetnav_env.core``) imports only the physics below it: astro, dynamics, sensors,
  estimation, attitude, numerics, scenarios, codes, errors and itself; not the configuration (``config``,
  ``options``, ``kernel_params``), the batch driver built from it (``batch``), the Gymnasium surface
  (``envs``), the tasks or the device package. The configuration meets the core in
  ``planetnav_env.kernel_params`` and ``planetnav_env.batch``, one layer up.
"""

from __future__ import annotations

import ast
from pathlib import Path

from test_import_graph import PACKAGES, project_modules

#: The product's packages (planetnav_validation is beside the product and may read its internals).
PRODUCT = ("planetnav_env", "planetnav_agents", "planetnav_train", "planetnav_rl")
#: What planetnav_env.core may import of planetnav_env (second component of the name).
CORE_MAY_IMPORT = {
    "core", "astro", "dynamics", "sensors", "estimation", "attitude", "numerics", "scenarios", "codes",
    "errors",
}  # fmt: skip
#: Imports across modules of one package that remain (none). The test fails when one of them is gone, so
#: the list only shrinks.
KNOWN_PRIVATE_IMPORTS: set[tuple[str, str]] = set()
#: The core's upward imports that remain (none: BatchCore, the Python driver of the row kernels built from
#: an EnvConfig, is planetnav_env.batch, above the core). Same rule: the test fails when one is gone.
KNOWN_CORE_UPWARD: set[tuple[str, str]] = set()


def _resolve(node: ast.ImportFrom, module: str, is_package: bool) -> str:
    """The absolute module name of ``from ... import`` in ``module``."""
    if not node.level:
        return node.module or ""
    package = module if is_package else module.rpartition(".")[0]
    parts = package.split(".")
    parts = parts[: len(parts) - (node.level - 1)]
    return ".".join(parts + ([node.module] if node.module else []))


def private_imports(path: Path, module: str) -> list[tuple[str, str]]:
    """``(module, source.name)`` for every underscore name (not a dunder) the file imports from a project
    module other than itself."""
    tree = ast.parse(path.read_text(), filename=str(path))
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            source = _resolve(node, module, path.name == "__init__.py")
            if source.split(".")[0] not in PACKAGES or source == module:
                continue
            for alias in node.names:
                name = alias.name
                if name.startswith("_") and not (name.startswith("__") and name.endswith("__")):
                    out.append((module, f"{source}.{name}"))
    return out


def _product_private_imports() -> set[tuple[str, str]]:
    found: set[tuple[str, str]] = set()
    for module, path in project_modules().items():
        if module.split(".")[0] in PRODUCT:
            found.update(private_imports(path, module))
    return found


def test_the_reader_finds_planted_private_imports(tmp_path: Path) -> None:
    mod = tmp_path / "m.py"
    mod.write_text(
        "from planetnav_env.attitude.pointing import _frame_batch, frame_batch\n"
        "from .sibling import _helper, __version__\n"
        "def f():\n    from planetnav_env.core.decisions import _SCALE\n"
    )
    assert sorted(private_imports(mod, "planetnav_agents.base")) == [
        ("planetnav_agents.base", "planetnav_agents.sibling._helper"),
        ("planetnav_agents.base", "planetnav_env.attitude.pointing._frame_batch"),
        ("planetnav_agents.base", "planetnav_env.core.decisions._SCALE"),
    ]


def test_no_product_module_imports_a_private_name_of_another_package() -> None:
    pairs = _product_private_imports()
    found = sorted(f"{m} imports {name}" for m, name in pairs if m.split(".")[0] != name.split(".")[0])
    assert not found, found


def test_private_names_stay_in_their_module() -> None:
    found = {(m, name) for m, name in _product_private_imports() if m.split(".")[0] == name.split(".")[0]}
    new = sorted(found - KNOWN_PRIVATE_IMPORTS)
    gone = sorted(KNOWN_PRIVATE_IMPORTS - found)
    assert not new, f"private names imported from another module (make them public there): {new}"
    assert not gone, f"no longer imported, remove from KNOWN_PRIVATE_IMPORTS: {gone}"


def above_the_core(name: str) -> bool:
    """Whether the imported dotted ``name`` lies in planetnav_env outside what the core may import."""
    parts = name.split(".")
    return parts[0] == "planetnav_env" and (len(parts) < 2 or parts[1] not in CORE_MAY_IMPORT)


def _core_upward() -> set[tuple[str, str]]:
    from test_import_graph import _imported_names

    out = set()
    for module, path in project_modules().items():
        if module.startswith("planetnav_env.core"):
            imported = _imported_names(path, module, path.name == "__init__.py")
            out.update((module, name) for name in imported if above_the_core(name))
    return out


def test_the_core_check_classifies_names() -> None:
    assert above_the_core("planetnav_env.config.EnvConfig")
    assert above_the_core("planetnav_env.options.kernel_fields")
    assert above_the_core("planetnav_env.envs.spaces")
    assert above_the_core("planetnav_env.device.blocks")
    assert above_the_core("planetnav_env.kernel_params.build_params")
    assert above_the_core("planetnav_env.batch.BatchCore")
    assert above_the_core("planetnav_env")  # the package's __init__ registers the ids with gymnasium
    assert not above_the_core("planetnav_env.estimation.ekf_kernels.KIND_CODES")
    assert not above_the_core("planetnav_env.core.layout")
    assert not above_the_core("numpy")


def test_the_reader_finds_a_planted_upward_import(tmp_path: Path) -> None:
    from test_import_graph import _imported_names

    mod = tmp_path / "m.py"
    mod.write_text(
        "from planetnav_env.core import layout\n"
        "def f():\n    from planetnav_env.batch import BatchCore\n    from planetnav_env import config\n"
    )
    names = _imported_names(mod, "planetnav_env.core.m", False)
    assert sorted(n for n in names if above_the_core(n)) == [
        "planetnav_env.batch.BatchCore",
        "planetnav_env.config",
    ]


def test_the_core_imports_nothing_above_it() -> None:
    found = _core_upward()
    new = sorted(found - KNOWN_CORE_UPWARD)
    gone = sorted(KNOWN_CORE_UPWARD - found)
    assert not new, f"planetnav_env.core imports above itself: {new}"
    assert not gone, f"no longer imported, remove from KNOWN_CORE_UPWARD: {gone}"


def test_the_core_records_and_params_read_no_configuration() -> None:
    """The records and the parameter helpers of the core, the kernels' inputs, import no configuration
    (their fields come in from planetnav_env.kernel_params)."""
    upward = {m for m, _ in _core_upward()}
    assert not upward & {"planetnav_env.core.records", "planetnav_env.core.params"}, sorted(_core_upward())
