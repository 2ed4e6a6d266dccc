"""mkdocs hooks (mkdocs.yml ``hooks:``) for the API reference: the package's folders as griffe sees
them, and each package's face expanded into one mkdocstrings entry per public name.

* The installed package maps folders at the repository's root (rt/, plant/, observer/, tracking/)
  to ``frictionrt.rt``, ``frictionrt.plant``, ... (pyproject's ``[tool.setuptools.package-dir]``).
  griffe reads sources without importing them and finds sub-packages by their folders, so
  ``on_config`` lays ``build/griffe_src/frictionrt/`` with a link per mapped package (from
  pyproject, so a new mapping needs nothing here); mkdocs.yml's handler ``paths`` points there.
* A package's face is lazy (``_EXPORTS = {name: module}`` in its ``__init__``, imported on first
  use), which static analysis cannot follow: a page's line ``<!-- face: frictionrt.plant -->``
  becomes ``::: frictionrt.plant`` (the package's docstring) and one ``::: module.name`` per name of
  ``_EXPORTS`` (read with ast, nothing imported), in the face's order.
"""
from __future__ import annotations

import ast
import os
import re
import tomllib
from pathlib import Path

from mkdocs.plugins import event_priority

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "build" / "griffe_src"
FACE = re.compile(r"^<!-- face: ([\w.]+) -->$", re.M)


def _mapping() -> dict[str, Path]:
    pyproject = tomllib.loads((ROOT / "pyproject.toml").read_text())
    dirs = pyproject["tool"]["setuptools"].get("package-dir", {})
    return {name: ROOT / folder for name, folder in dirs.items() if name}


def _package_dir(package: str) -> Path:
    """The folder of a dotted package name, through pyproject's package-dir mapping."""
    mapping = _mapping()
    parts = package.split(".")
    for k in range(len(parts), 0, -1):
        head = ".".join(parts[:k])
        if head in mapping:
            return mapping[head].joinpath(*parts[k:])
    return ROOT.joinpath(*parts)


def face_names(package: str) -> list[tuple[str, str]]:
    """(name, module) of each public name of ``package``'s lazy face, in its ``_EXPORTS`` order;
    [] for a package without one."""
    tree = ast.parse((_package_dir(package) / "__init__.py").read_text())
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(node, ast.AnnAssign) else []
        if any(isinstance(t, ast.Name) and t.id == "_EXPORTS" for t in targets) and isinstance(node.value, ast.Dict):
            return [(ast.literal_eval(k), ast.literal_eval(v)) for k, v in zip(node.value.keys, node.value.values)]
    return []


@event_priority(100)  # before mkdocstrings reads its handler's paths
def on_config(config, **kwargs):
    top = SRC / "frictionrt"
    top.mkdir(parents=True, exist_ok=True)
    for name, folder in _mapping().items():
        link = SRC.joinpath(*name.split("."))
        if name == "frictionrt":
            for f in folder.glob("*.py"):
                target = link / f.name
                if not target.is_symlink():
                    target.unlink(missing_ok=True)
                    os.symlink(f, target)
            continue
        if link.is_symlink() and link.resolve() == folder.resolve():
            continue
        if link.is_symlink():
            link.unlink()
        os.symlink(folder, link, target_is_directory=True)
    return config


def on_page_markdown(markdown, page, config, files, **kwargs):
    def expand(m: re.Match) -> str:
        package = m.group(1)
        blocks = [f"::: {package}\n    options:\n      members: false\n      heading_level: 2"]
        blocks += [f"::: {module}.{name}" for name, module in face_names(package)]
        return "\n\n".join(blocks)
    return FACE.sub(expand, markdown)
