"""Experiments on the loop: step-sine FRFs, the paper's reproduction and its claims, gain tuning,
the laws side by side.

Modules: ``stepsine`` (the step-sine method), ``branches`` (sweeps in processes or on dask),
``reproduce`` (what the reproduction runs and measures), ``claims`` (C1..C6 as pure
functions), ``reproduce_report`` (figures and report files), ``tune`` (grid search of gains),
``compare`` (the three laws at one excitation). A verb-named function lives in its module
(``rt.experiments.tune.tune``). The names below are imported on first use (rt/common/face.py).
"""
from rt.common.face import lazy_face

_EXPORTS = {
    "Branch": "rt.experiments.branches", "connect": "rt.experiments.branches", "Settle": "rt.experiments.stepsine", "StepSineResult": "rt.experiments.stepsine", "run_branches": "rt.experiments.branches", "resonance_grid": "rt.experiments.stepsine", "mode_bands_hz": "rt.experiments.stepsine",
    "FULL": "rt.experiments.reproduce", "QUICK": "rt.experiments.reproduce", "measure": "rt.experiments.reproduce", "loop_at_fn1": "rt.experiments.reproduce",
    "write_outputs": "rt.experiments.reproduce_report",
    "peak_reduction_db": "rt.experiments.claims",
    "DEFAULT_GRIDS": "rt.experiments.tune", "parse_grid": "rt.experiments.tune", "best_toml": "rt.experiments.tune",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
