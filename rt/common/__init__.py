"""The bottom of frictionrt: configuration, clock slots, noise, the kernels' code generation and cache.

Importing this package fixes numba's code-generation target (``codegen``) and points its cache
at a directory keyed on the kernel sources (``jit_cache``), before any kernel compiles;
plant/, observer/, tracking/ and rt/ import it first for that reason. Nothing here imports
another frictionrt package.
"""
from rt.common.codegen import configure as _configure_codegen

_configure_codegen()  # before numba is imported: the kernels' fixed code-generation target

from rt.common.jit_cache import configure as _configure_jit_cache  # noqa: E402  (imports numba)

_configure_jit_cache()
