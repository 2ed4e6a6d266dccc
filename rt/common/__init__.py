"""The bottom of frictionrt: configuration, clock slots, noise, the kernels' code generation and cache.

Importing this package fixes OpenBLAS's kernels and thread count (``blas``) before numpy loads it,
numba's code-generation target (``codegen``), and points numba's cache at a directory keyed on the
kernel sources (``jit_cache``), before any kernel compiles;
plant/, observer/, tracking/ and rt/ import it first for that reason. Nothing here imports
another frictionrt package (the layers contract in pyproject.toml).

Modules: ``config`` (the one typed configuration), ``clock`` (the monotonic clock for kernels
and the loop's clock slots), ``noise`` (the kernels' random numbers), ``blas``, ``codegen``,
``jit_cache``, ``face`` (how packages offer their names). The names below are imported on
first use (rt/common/face.py).
"""
from rt.common.blas import configure as _configure_blas
from rt.common.codegen import configure as _configure_codegen

_configure_blas()     # before numpy is imported: OpenBLAS's pinned kernels and thread count
_configure_codegen()  # before numba is imported: the kernels' fixed code-generation target

from rt.common.jit_cache import configure as _configure_jit_cache  # noqa: E402  (imports numba)

_configure_jit_cache()

from rt.common.face import lazy_face  # noqa: E402

_EXPORTS = {
    "Config": "rt.common.config", "ConfigError": "rt.common.config", "LAWS": "rt.common.config",
    "load": "rt.common.config", "loads": "rt.common.config", "dumps": "rt.common.config",
    "with_sets": "rt.common.config", "to_dict": "rt.common.config", "check_key": "rt.common.config",
    "new_rng": "rt.common.noise", "compiled_target": "rt.common.codegen", "source_hash": "rt.common.jit_cache",
    "lazy_face": "rt.common.face",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
