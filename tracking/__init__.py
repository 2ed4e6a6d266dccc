"""Tracking: control laws, RT1 filter, force tracking, output low-pass (frictionrt)."""
import rt.common  # noqa: F401  (numba's code-generation target and source-keyed cache, before any kernel compiles)
