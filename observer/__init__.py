"""Observer: the Kalman-designed nonlinear observer (frictionrt)."""
import rt  # noqa: F401  (sets numba's source-keyed cache directory before any kernel compiles)
