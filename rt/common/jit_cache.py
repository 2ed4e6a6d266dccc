"""Numba's on-disk cache, keyed on the source of every kernel.

Numba invalidates a cached function only when its own file changes: ``frictionrt.plant.simulate._run``
keeps the machine code of an old ``frictionrt.plant.newmark._plant_step`` after newmark.py is edited
(it happened). The cache directory is therefore named after a hash of the kernel sources, so
any edit to them starts a fresh cache. Kernel sources are every .py file of plant/,
observer/ and tracking/ (sub-packages included), those of rt/ and its sub-packages that define
an njit function, and rt/common/config.py (whose constants kernels may capture); rt's
command-line, logging and experiment modules are left out, so editing them does not cost a
recompile. ``configure`` must run before the first ``numba.njit(cache=True)`` decorator
executes; ``frictionrt.rt.common``'s ``__init__`` calls it, and every package imports ``frictionrt.rt.common``
first. A user's own NUMBA_CACHE_DIR is respected (and then invalidation is theirs to manage).
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba

PACKAGES = ("rt", "plant", "observer", "tracking")
ROOT = Path(__file__).resolve().parents[2]  # the folder holding the packages (rt/common/jit_cache.py)
CONFIG = Path("rt", "common", "config.py")


def kernel_sources(root: Path = ROOT) -> list[Path]:
    """The files under ``root`` whose edit must invalidate the cache (see the module docstring)."""
    files = []
    for pkg in PACKAGES:
        for f in sorted((root / pkg).rglob("*.py")):
            rel = f.relative_to(root)
            if pkg != "rt" or rel == CONFIG or "njit" in f.read_text():
                files.append(f)
    return files


def source_hash(root: Path = ROOT) -> str:
    """SHA-256 (first 16 hex digits) over ``kernel_sources(root)``: their paths relative to
    ``root`` and their bytes, and numba's version."""
    h = hashlib.sha256()
    for f in kernel_sources(root):
        h.update(f.relative_to(root).as_posix().encode())
        h.update(f.read_bytes())
    h.update(numba.__version__.encode())
    return h.hexdigest()[:16]


def cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "frictionrt" / f"numba-{source_hash()}"


def configure() -> None:
    """Point numba's cache at ``cache_dir()`` unless NUMBA_CACHE_DIR is set."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return
    numba.config.CACHE_DIR = str(cache_dir())
