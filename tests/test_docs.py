"""The documentation's rules: the user docs and the sources cite no issue or stop numbers (the
measurement history is the record, docs/studies/), the README's first screen fits a screen, and the
API reference builds from the docstrings with warnings as errors (mkdocs.yml; skipped without the
``docs`` extra)."""
from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# "issue 31", "issues 7, 18", "stop 42", "stops 38-39", "PR #12", a bare "#12"; not "cpython#90882"
# (another project's tracker, named) nor a Markdown anchor "(file.md#1-equations)"
INTERNAL_REF = re.compile(r"\b(?:[Ii]ssues?|[Ss]tops?|PR|[Pp]ull\s+request)\s+#?\d+|(?<![\w/.&-])#\d+\b")
SOURCE_DIRS = ("frictionrt", "rt", "plant", "observer", "tracking")
# files whose remaining hit is another owner's to remove (a --help text of the CLI); the test fails
# as soon as one is clean, so the entry cannot outlive its reason
PENDING: set[str] = set()
FIRST_SCREEN_LINES = 40
FIRST_SCREEN_WIDTH = 100


def _user_docs() -> list[Path]:
    docs = sorted(p for p in (ROOT / "docs").rglob("*.md") if "studies" not in p.relative_to(ROOT / "docs").parts)
    return [ROOT / "README.md", *docs]


def _hits(path: Path) -> list[str]:
    """Every reference in the file, also one broken across a line ("issue\\n18")."""
    text = path.read_text()
    return [f"{path.relative_to(ROOT)}:{text.count(chr(10), 0, m.start()) + 1}: {m.group(0)!r}"
            for m in INTERNAL_REF.finditer(text)]


def test_internal_reference_pattern():
    """The pattern catches the spellings the history used and spares external references."""
    caught = ["since issue 32", "issues 7, 18", "(stop 42)", "Stop 40, seed 5", "stops 38-39", "PR #1212",
              "see #31", "written before issue\n18"]
    spared = ["cpython#90882", "python-control#1212", "[x](spec.md#5-observer)", "a 1 % step", "stop at < 0.1 %",
              "tissue 3"]
    assert all(INTERNAL_REF.search(s) for s in caught), [s for s in caught if not INTERNAL_REF.search(s)]
    assert not any(INTERNAL_REF.search(s) for s in spared), [s for s in spared if INTERNAL_REF.search(s)]


def test_user_docs_cite_no_issue_or_stop_numbers():
    """README.md and docs/ outside docs/studies/ state what is true now; the history is the record."""
    hits = [h for p in _user_docs() for h in _hits(p)]
    assert not hits, "issue/stop numbers in the user docs (move the history to docs/studies/):\n" + "\n".join(hits)


def test_sources_cite_no_issue_or_stop_numbers():
    """Docstrings and comments state the contract; the history is in the commits and docs/studies/
    (tests/ and benchmarks/ may cite the issue they measure)."""
    files = sorted(p for d in SOURCE_DIRS for p in (ROOT / d).rglob("*.py"))
    assert len(files) > 100, "the source folders were not found"
    hits, clean_pending = [], []
    for p in files:
        rel = p.relative_to(ROOT).as_posix()
        found = _hits(p)
        if rel in PENDING:
            clean_pending += [] if found else [rel]
        else:
            hits += found
    assert not hits, "issue/stop numbers in the sources:\n" + "\n".join(hits)
    assert not clean_pending, f"remove {clean_pending} from PENDING in tests/test_docs.py: they are clean now"


def test_readme_first_screen_fits_a_screen():
    """Everything before the README's first ``##``: at most 40 lines, none over 100 characters."""
    lines = (ROOT / "README.md").read_text().splitlines()
    end = next(i for i, line in enumerate(lines) if line.startswith("## "))
    screen = lines[:end]
    while screen and not screen[-1].strip():
        screen.pop()
    wide = [f"{i + 1}: {len(line)} characters" for i, line in enumerate(screen) if len(line) > FIRST_SCREEN_WIDTH]
    assert len(screen) <= FIRST_SCREEN_LINES, f"the first screen is {len(screen)} lines"
    assert not wide, wide
    for needed in ("make demo", "make test", "docs/recipes/"):
        assert needed in "\n".join(screen), f"the first screen does not name {needed}"


def test_studies_are_indexed():
    """Every record file is reachable from the record's index, and every guide page from the docs index."""
    studies = ROOT / "docs" / "studies"
    index = (studies / "README.md").read_text()
    missing = [p.name for p in sorted(studies.glob("*.md")) if p.name != "README.md" and f"({p.name})" not in index]
    assert not missing, f"docs/studies/README.md does not link {missing}"
    docs_index = (ROOT / "docs" / "index.md").read_text()
    pages = [p.relative_to(ROOT / "docs").as_posix() for p in sorted((ROOT / "docs").glob("*.md"))
             + sorted((ROOT / "docs" / "recipes").glob("*.md"))]
    missing = [p for p in pages if p != "index.md" and f"({p})" not in docs_index]
    assert not missing, f"docs/index.md does not link {missing}"


@pytest.mark.skipif(importlib.util.find_spec("mkdocs") is None or importlib.util.find_spec("mkdocstrings") is None,
                    reason="the docs extra (mkdocs, mkdocstrings[python]) is not installed")
def test_reference_builds_without_warnings(tmp_path):
    """``mkdocs build --strict``: the guide, the recipes and the API reference generated from the
    docstrings (griffe reads the sources, nothing is imported), every warning an error."""
    run = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-4000:]
    assert (tmp_path / "site" / "reference" / "index.html").exists()
