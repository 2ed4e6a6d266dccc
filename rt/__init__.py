"""Real-time loop, configuration, CLI, timing (frictionrt)."""
from rt.jit_cache import configure as _configure_jit_cache

_configure_jit_cache()
