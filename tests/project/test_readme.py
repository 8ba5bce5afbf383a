"""The README's code is tested: every ```python block runs as written, with warnings as errors
(tests/project/test_readme_snippets.py), every ``python train.py <command>`` it names is a command of
train.py's CLI, and the files it and the reference pages link to exist. Shell blocks are not executed (they
train for minutes)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
#: The README is a front page; results and history live in docs/ and research/.
MAX_README_LINES = 250
#: Pages whose relative links are checked besides the README.
LINKED_PAGES = [README, ROOT / "docs" / "performance.md", ROOT / "docs" / "validation.md",
                *sorted((ROOT / "docs" / "tasks").glob("*.md"))]  # fmt: skip

_FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.MULTILINE | re.DOTALL)


def code_blocks(text: str, language: str) -> list[str]:
    """The bodies of the fenced blocks of ``language`` in markdown ``text``, in order."""
    return [body for lang, body in _FENCE.findall(text) if lang == language]


PYTHON_BLOCKS = code_blocks(README.read_text(), "python")


def test_readme_is_a_front_page() -> None:
    """At most MAX_README_LINES lines, with the quickstarts it promises."""
    lines = README.read_text().splitlines()
    assert len(lines) <= MAX_README_LINES, f"README.md has {len(lines)} lines (at most {MAX_README_LINES})"
    assert any("gym.make(" in b for b in PYTHON_BLOCKS), "no single-environment quickstart"
    assert any("gym.make_vec(" in b for b in PYTHON_BLOCKS), "no vector-environment quickstart"


def test_readme_train_commands_exist() -> None:
    """Every ``python train.py <command>`` in the README is a command of train.py (its --help lists them)."""
    named = set(re.findall(r"python train\.py ([a-z][a-z-]*)", README.read_text()))
    assert named, "the README names no train.py command"
    help_text = subprocess.run(
        [sys.executable, "train.py", "--help"], cwd=ROOT, capture_output=True, text=True, timeout=300,
        check=True,
    ).stdout  # fmt: skip
    choices = re.search(r"\{([a-z,-]+)\}", help_text)
    assert choices, help_text
    commands = set(choices.group(1).split(","))
    assert named <= commands, f"not train.py commands: {sorted(named - commands)} (of {sorted(commands)})"


def test_readme_config_paths_exist() -> None:
    """Every configs/*.yaml the README names is a file."""
    paths = set(re.findall(r"configs/[\w/.-]+\.yaml", README.read_text()))
    missing = sorted(p for p in paths if not (ROOT / p).is_file())
    assert not missing, f"README names missing configs: {missing}"


@pytest.mark.parametrize("page", LINKED_PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_resolve(page: Path) -> None:
    """Every relative markdown link of the page points to an existing file or folder."""
    targets = re.findall(r"\]\(([^)\s]+)\)", page.read_text())
    local = [t.split("#", 1)[0] for t in targets if not re.match(r"[a-z]+:", t) and not t.startswith("#")]
    missing = sorted({t for t in local if t and not (page.parent / t).exists()})
    assert not missing, f"{page.relative_to(ROOT)}: broken links {missing}"
