"""Plant: FE beams, contact and friction, Craig-Bampton, Newmark/Newton step (frictionrt)."""
import rt.common  # noqa: F401  (numba's code-generation target and source-keyed cache, before any kernel compiles)
