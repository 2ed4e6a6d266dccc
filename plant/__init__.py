"""Plant: FE beams, contact and friction, Craig-Bampton, Newmark/Newton step (frictionrt)."""
import rt  # noqa: F401  (sets numba's source-keyed cache directory before any kernel compiles)
