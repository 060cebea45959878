"""The repo stands alone: no README, docstring or comment points outside it (issue 21, item 8)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_nothing_refers_outside_the_repo():
    pattern = re.compile(r"\.\./shared|shared/(DESIGN|APIS)\.md|\bDESIGN\.md\b|\bAPIS\.md\b")
    files = [ROOT / "README.md", ROOT / "pyproject.toml", ROOT / "mkdocs.yml", *ROOT.glob("docs/**/*.md"),
             *ROOT.glob("*/**/*.py")]
    hits = [f"{p.relative_to(ROOT)}:{i}" for p in files if ".venv" not in p.parts and p != Path(__file__)
            for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1) if pattern.search(line)]
    assert not hits, hits
