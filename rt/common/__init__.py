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
from frictionrt.rt.common.blas import configure as _configure_blas
from frictionrt.rt.common.codegen import configure as _configure_codegen

_configure_blas()     # before numpy is imported: OpenBLAS's pinned kernels and thread count
_configure_codegen()  # before numba is imported: the kernels' fixed code-generation target

from frictionrt.rt.common.jit_cache import configure as _configure_jit_cache  # noqa: E402  (imports numba)

_configure_jit_cache()

from frictionrt.rt.common.face import lazy_face  # noqa: E402

_EXPORTS = {
    "Config": "frictionrt.rt.common.config", "ConfigError": "frictionrt.rt.common.config", "LAWS": "frictionrt.rt.common.config",
    "load": "frictionrt.rt.common.config", "loads": "frictionrt.rt.common.config", "dumps": "frictionrt.rt.common.config",
    "with_sets": "frictionrt.rt.common.config", "to_dict": "frictionrt.rt.common.config", "check_key": "frictionrt.rt.common.config",
    "new_rng": "frictionrt.rt.common.noise", "compiled_target": "frictionrt.rt.common.codegen", "source_hash": "frictionrt.rt.common.jit_cache",
    "lazy_face": "frictionrt.rt.common.face",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
