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

Numba keeps no lock between processes: two that need the same uncached kernel at once (test workers,
``reproduce``'s and ``diagnose``'s process pools) each compile it in full. ``configure`` therefore
also puts a file lock around each cached kernel's compile (``install_compile_lock``): the second
process waits for the first and then loads the machine code from the cache.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

try:
    import fcntl
except ImportError:      # not POSIX: no lock between processes (each compiles for itself, as numba does)
    fcntl = None

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
    """Point numba's cache at ``cache_dir()`` unless NUMBA_CACHE_DIR is set; lock compiles between
    processes (``install_compile_lock``)."""
    if not os.environ.get("NUMBA_CACHE_DIR"):
        numba.config.CACHE_DIR = str(cache_dir())
    install_compile_lock()


def lock_path(py_func, args: tuple, folder: Path | None = None) -> Path:
    """The lock file of a kernel's compile for the argument types ``args``:
    ``locks/<module>.<qualname>-<sha256 of the types, 12 hex>.lock`` in numba's cache folder (one per
    signature, so that two processes compiling a kernel for different types do not wait for each other);
    ``folder`` overrides the cache folder."""
    if folder is None:
        folder = Path(numba.config.CACHE_DIR) if numba.config.CACHE_DIR else cache_dir()
    name = "".join(c if c.isalnum() or c in "._-" else "_" for c in f"{py_func.__module__}.{py_func.__qualname__}")
    return folder / "locks" / f"{name}-{hashlib.sha256(str(tuple(args)).encode()).hexdigest()[:12]}.lock"


def install_compile_lock() -> None:
    """Wrap ``numba.core.dispatcher.Dispatcher.compile`` so that a kernel with ``cache=True`` compiles
    under an exclusive ``flock`` on its ``lock_path`` for the signature (taken inside numba's own compiler lock): a process
    that finds another compiling it waits, then numba's compile finds the other's result in the disk
    cache and loads it. Signatures already in memory and kernels without a disk cache pass without the
    lock. A kernel's callees lock in turn while it holds its own lock; call graphs have no cycles, so
    two processes cannot wait for each other. Without fcntl, or where the lock file cannot be opened,
    numba compiles as it would alone. Idempotent."""
    from numba.core import dispatcher, sigutils
    from numba.core.caching import NullCache
    from numba.core.compiler_lock import global_compiler_lock

    original = dispatcher.Dispatcher.compile
    if fcntl is None or getattr(original, "frictionrt_lock", False):
        return

    def compile(self, sig):
        if isinstance(self._cache, NullCache):
            return original(self, sig)
        with global_compiler_lock:
            args = tuple(sigutils.normalize_signature(sig)[0])
            if self.overloads.get(args) is not None:
                return original(self, sig)
            path = lock_path(self.py_func, args)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                fh = open(path, "a")
            except OSError:
                return original(self, sig)
            with fh:
                fcntl.flock(fh, fcntl.LOCK_EX)
                return original(self, sig)   # closing the file releases the lock

    compile.frictionrt_lock = True
    dispatcher.Dispatcher.compile = compile
