"""Experiments on the loop: step-sine FRFs, the paper's reproduction and its claims, gain tuning,
the laws side by side.

Modules: ``stepsine`` (the step-sine method), ``branches`` (sweeps in processes or on dask),
``reproduce`` (what the reproduction runs and measures), ``claims`` (C1..C6 as pure
functions), ``reproduce_report`` (figures and report files), ``tune`` (grid search of gains),
``compare`` (the three laws at one excitation). A verb-named function lives in its module
(``frictionrt.rt.experiments.tune.tune``). The names below are imported on first use (rt/common/face.py).
"""
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "Branch": "frictionrt.rt.experiments.branches", "connect": "frictionrt.rt.experiments.branches", "Settle": "frictionrt.rt.experiments.stepsine", "StepSineResult": "frictionrt.rt.experiments.stepsine", "run_branches": "frictionrt.rt.experiments.branches", "resonance_grid": "frictionrt.rt.experiments.stepsine", "mode_bands_hz": "frictionrt.rt.experiments.stepsine",
    "FULL": "frictionrt.rt.experiments.reproduce", "QUICK": "frictionrt.rt.experiments.reproduce", "measure": "frictionrt.rt.experiments.reproduce", "loop_at_fn1": "frictionrt.rt.experiments.reproduce",
    "write_outputs": "frictionrt.rt.experiments.reproduce_report",
    "peak_change_db": "frictionrt.rt.experiments.claims",
    "DEFAULT_GRIDS": "frictionrt.rt.experiments.tune", "parse_grid": "frictionrt.rt.experiments.tune", "best_toml": "frictionrt.rt.experiments.tune",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
