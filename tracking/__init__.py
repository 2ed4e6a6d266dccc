"""Tracking: control laws, RT1 filter, force tracking, output low-pass (frictionrt)."""
import rt  # noqa: F401  (sets numba's source-keyed cache directory before any kernel compiles)
