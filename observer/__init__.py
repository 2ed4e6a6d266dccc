"""Observer: the Kalman-designed nonlinear observer (frictionrt)."""
import rt.common  # noqa: F401  (numba's code-generation target and source-keyed cache, before any kernel compiles)
