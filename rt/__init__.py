"""Real-time loop, configuration, CLI, timing (frictionrt)."""
from rt.codegen import configure as _configure_codegen

_configure_codegen()  # before numba is imported: the kernels' fixed code-generation target (rt/codegen.py)

from rt.jit_cache import configure as _configure_jit_cache  # noqa: E402  (imports numba)

_configure_jit_cache()
