"""The LICENSE file is the license that pyproject.toml and CITATION.cff declare, held by their authors."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]


def test_license_file_matches_the_declared_license() -> None:
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["license"]
    citation = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert declared == citation["license"] == "MIT"
    text = (ROOT / "LICENSE").read_text()
    assert text.splitlines()[0] == "MIT License"
    assert "Permission is hereby granted, free of charge" in text
    holder = re.search(r"^Copyright \(c\) (\d{4}) (.+)$", text, re.MULTILINE)
    assert holder, "LICENSE has no copyright line"
    assert holder.group(2) == citation["authors"][0]["name"]
