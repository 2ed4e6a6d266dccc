"""Tracking: control laws, RT1 filter, force tracking, the biquad low-passes (frictionrt).

Modules: ``laws`` (passive, hysteresis-optimal, Lyapunov), ``rt1``, ``prefilter``,
``force_tracking`` (PID + feedforward), ``lowpass`` (the biquad the prefilter and the oracle
use). The names below are imported on first use (rt/common/face.py).
"""
import frictionrt.rt.common  # noqa: F401  (numba's code-generation target and source-keyed cache, before any kernel compiles)
from frictionrt.rt.common.face import lazy_face  # noqa: E402

_EXPORTS = {
    "build_laws": "frictionrt.tracking.laws",
    "build_rt1": "frictionrt.tracking.rt1",
    "build_prefilter": "frictionrt.tracking.prefilter",
    "design_force_tracking": "frictionrt.tracking.force_tracking",
    "BiquadParams": "frictionrt.tracking.lowpass", "build_butter2": "frictionrt.tracking.lowpass",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
