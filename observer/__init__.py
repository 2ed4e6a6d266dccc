"""Observer: the Kalman-designed nonlinear observer, and the oracle it is compared with (frictionrt).

Modules: ``model`` (the simplified linear model), ``kalman`` (the design), ``step`` (the
run-time kernel), ``atan`` (fdlibm's arctan), ``oracle``, ``accuracy``, ``offline`` (filterpy's
filters on a logged run). The names below are imported on first use (rt/common/face.py).
"""
import rt.common  # noqa: F401  (numba's code-generation target and source-keyed cache, before any kernel compiles)
from rt.common.face import lazy_face  # noqa: E402

_EXPORTS = {
    "ObserverParams": "observer.kalman", "design_observer": "observer.kalman",
    "build_observer_model": "observer.model",
    "build_oracle": "observer.oracle",
    "band_limited_truth": "observer.accuracy", "nrmse": "observer.accuracy",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
