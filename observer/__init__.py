"""Observer: the Kalman-designed nonlinear observer, and the oracle it is compared with (frictionrt).

Modules: ``model`` (the simplified linear model), ``kalman`` (the design), ``step`` (the
run-time kernel), ``amplitude`` and ``amplitude_step`` (the amplitude-following kind's design and
kernel), ``atan`` (fdlibm's arctan), ``oracle``, ``accuracy``, ``offline`` (filterpy's
filters on a logged run). The names below are imported on first use (rt/common/face.py).
"""
import frictionrt.rt.common  # noqa: F401  (numba's code-generation target and source-keyed cache, before any kernel compiles)
from frictionrt.rt.common.face import lazy_face  # noqa: E402

_EXPORTS = {
    "ObserverParams": "frictionrt.observer.kalman", "design_observer": "frictionrt.observer.kalman",
    "build_observer_model": "frictionrt.observer.model",
    "AmplitudeParams": "frictionrt.observer.amplitude", "design_amplitude": "frictionrt.observer.amplitude",
    "build_oracle": "frictionrt.observer.oracle",
    "band_limited_truth": "frictionrt.observer.accuracy", "nrmse": "frictionrt.observer.accuracy",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
