"""The fixed-step loop (SPEC section 7): design, the compiled tick and its pacing, the thread
driver, the figures of a run; the supervisor and faults, replay, the timing budget.

Modules: ``build`` (``Loop``, ``build_loop``, ``LoopState``), ``tick`` (the compiled tick),
``pacing`` (the deadlines the loop and the replay share), ``driver`` (``run``), ``results``
(``summary``), ``realtime`` (a paced run's priority, pinning, memory lock), ``floor`` (the null
loop and cyclictest), ``supervisor``, ``faults``, ``digest`` (a ring run's whole-run figures),
``replay``, ``replay_plant``, ``budget``, ``bench``. A verb-named function lives in its module
(``frictionrt.rt.loop.replay.replay``). The names below are imported on first use (rt/common/face.py).
"""
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "COMPONENTS": "frictionrt.rt.loop.build", "Designs": "frictionrt.rt.loop.build", "ESTIMATORS": "frictionrt.rt.loop.build", "Loop": "frictionrt.rt.loop.build",
    "LoopState": "frictionrt.rt.loop.build", "build_loop": "frictionrt.rt.loop.build", "initial_loop_state": "frictionrt.rt.loop.build",
    "loop_signals": "frictionrt.rt.loop.build",
    "Run": "frictionrt.rt.loop.driver", "check_run_input": "frictionrt.rt.loop.driver", "run": "frictionrt.rt.loop.driver",
    "first_harmonic_amplitude": "frictionrt.rt.loop.results", "summary": "frictionrt.rt.loop.results",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
