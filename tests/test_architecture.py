"""The package structure (issue 16): import layers and cycles, the packages' faces, module size,
and the docs' links to files.

The layers (the packages', and rt.discrepancy's sub-packages') and the acyclic-siblings rule are
import-linter contracts in pyproject.toml
(``lint-imports`` prints them); this test runs them, so pytest fails like ``make test`` does.
"""
from __future__ import annotations

import ast
import importlib
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("frictionrt.rt.common", "frictionrt.rt.log", "frictionrt.rt.loop", "frictionrt.rt.experiments",
            "frictionrt.rt.export", "frictionrt.rt.discrepancy", "frictionrt.rt.discrepancy.rig",
            "frictionrt.rt.discrepancy.diagnose", "frictionrt.rt.cli", "frictionrt.plant", "frictionrt.observer",
            "frictionrt.tracking")
MAX_LINES = 500  # the guide; a longer module gives its reason in a "Length:" paragraph of its docstring


def _lint_imports() -> str:
    exe = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    if not Path(exe).exists():
        pytest.fail("import-linter is not installed: the import contracts cannot be checked (pip install -e '.[test]')")
    return exe


def _package_dirs() -> dict[str, str]:
    return tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["package-dir"]


def _installed_tree(dest: Path) -> Path:
    """The packages as a wheel installs them (pyproject's package-dir: rt/ -> frictionrt/rt/, ...)
    under ``dest``. import-linter's graph builder walks a root package's folder on disk, and in
    the clone frictionrt.rt lives beside frictionrt/, not in it."""
    for name, folder in sorted(_package_dirs().items()):
        target = dest.joinpath(*name.split("."))
        shutil.copytree(ROOT / folder, target, dirs_exist_ok=True,
                        ignore=shutil.ignore_patterns("__pycache__", "templates"))
    shutil.copy(ROOT / "pyproject.toml", dest)
    return dest


def _run_lint(tree: Path) -> subprocess.CompletedProcess:
    return subprocess.run([_lint_imports(), "--no-cache"], cwd=tree, capture_output=True, text=True,
                          env={"PYTHONPATH": str(tree), "PATH": "/usr/bin:/bin", "COLUMNS": "1000"})


def test_packages_listed_in_pyproject_are_the_folders():
    # pyproject lists the installed packages by hand (the package-dir mapping rules out
    # packages.find): a new sub-package must be added there, or a wheel would leave it out
    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {"frictionrt"}
    for name, folder in _package_dirs().items():
        for init in (ROOT / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(ROOT / folder)
            found.add(".".join([name, *rel.parts]))
    assert listed == found, f"pyproject's [tool.setuptools] packages differ: missing {sorted(found - listed)}, extra {sorted(listed - found)}"


def test_import_contracts_hold(tmp_path):
    # higher layers import lower ones only, and no two sibling packages or modules import each
    # other (cycles); output names the offending import chain
    r = _run_lint(_installed_tree(tmp_path))
    assert r.returncode == 0, r.stdout[-3000:] + r.stderr[-2000:]
    assert "3 kept, 0 broken" in r.stdout


@pytest.mark.parametrize("module, line, message", [
    # the log package importing the loop (the writer's old CLK_* import)
    ("frictionrt/rt/log/writer.py", "from frictionrt.rt.loop.driver import run",
     "frictionrt.rt.log is not allowed to import frictionrt.rt.loop"),
    # the rig importing the diagnosis (rt.discrepancy's sub-packages)
    ("frictionrt/rt/discrepancy/rig/frf.py", "from frictionrt.rt.discrepancy.diagnose.campaign import bic",
     "frictionrt.rt.discrepancy.rig is not allowed to import frictionrt.rt.discrepancy.diagnose"),
], ids=["log-loop", "rig-diagnose"])
def test_a_layer_violation_breaks_the_contract(tmp_path, module, line, message):
    # the contracts can fail
    tree = _installed_tree(tmp_path)
    path = tree / module
    path.write_text(path.read_text() + f"\n{line}  # noqa\n")
    r = _run_lint(tree)
    assert r.returncode != 0 and message in r.stdout, r.stdout[-2000:]


@pytest.mark.parametrize("package", PACKAGES)
def test_every_face_name_resolves_and_shadows_no_module(package):
    mod = importlib.import_module(package)
    assert mod.__doc__ and len(mod.__doc__) > 40, f"{package} needs a docstring saying what it holds"
    names = getattr(mod, "__all__", None)
    assert names, f"{package}: no __all__ (its face)"
    folder = Path(mod.__file__).parent
    modules = {f.stem for f in folder.glob("*.py")}
    for name in names:
        assert getattr(mod, name) is not None
        assert name not in modules, f"{package}.{name} is both a face name and a module"


def _modules():
    for pkg in ("frictionrt", "rt", "plant", "observer", "tracking"):
        yield from sorted((ROOT / pkg).rglob("*.py"))


def test_modules_are_short_or_say_why():
    long = []
    for f in _modules():
        n = len(f.read_text().splitlines())
        doc = ast.get_docstring(ast.parse(f.read_text())) or ""
        if n > MAX_LINES and "Length:" not in doc:
            long.append(f"{f.relative_to(ROOT)} ({n} lines)")
    assert not long, f"over {MAX_LINES} lines without a 'Length:' reason in the docstring: {long}"


LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
PATH = re.compile(r"`((?:rt|plant|observer|tracking|tests|benchmarks|docs|configs)/[\w/.-]+\.(?:py|md|toml))`")


def test_no_merge_conflict_markers_are_left():
    """A merge's conflict markers once stayed in docs/discrepancy.md for a stop: every tracked text
    file (git ls-files) is free of lines that start with them."""
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True, check=True).stdout.split()
    marker = re.compile(r"^(<<<<<<< |>>>>>>> |=======$)", re.M)
    hits = [f for f in files if f.endswith((".py", ".md", ".toml", ".txt", ".cfg", ".yml", ".yaml"))
            and marker.search((ROOT / f).read_text(errors="replace"))]
    assert not hits, hits


def test_docs_links_and_file_references_resolve():
    # every relative link of README.md and docs/**/*.md, and every `package/file.py` they name
    missing = []
    for md in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        text = md.read_text()
        for target in LINK.findall(text):
            if "://" in target or target.startswith("mailto:"):
                continue
            if not (md.parent / target).exists():
                missing.append(f"{md.relative_to(ROOT)}: link {target}")
        for target in PATH.findall(text):
            if not (ROOT / target).exists():
                missing.append(f"{md.relative_to(ROOT)}: {target}")
    assert not missing, "\n".join(missing)
