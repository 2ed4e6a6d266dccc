"""The diagnosis (``frictionrt diagnose``, docs/discrepancy.md): where model and measurement
disagree, which effect of the library is missing, how much of the gap it closes, and the report.

Modules: ``campaign`` (a time-series campaign: the workflow, its actuator channel and the BIC
ranking the other inputs share), ``structure`` (the structural fit of the impulse tests),
``stepsine`` (the step-sine channel: the shaker), ``frf`` (a folder of FRF files) with
``frf_modes`` (measured modes paired with the model's), ``levels`` (FRFs at several levels:
``--calibrate-on``), ``plausible`` (the calibrated parameters' plausible ranges and the fits' penalty
outside them), ``remainder`` (what calibration, the effect and the model form explain), ``watch`` (the fits'
progress bars, their parallel runs, and Ctrl-C that keeps the fits done),
``report`` and ``rrd`` (the report folder and its rerun file). Imports rt.discrepancy.rig (the
FRF files' sensor points, the levels report's new folder) and the shared modules. A verb-named function
is on this face (``frictionrt.rt.discrepancy.diagnose.diagnose``, defined in ``campaign``). The names below
are imported on first use (rt/common/face.py).
"""
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "diagnose": "frictionrt.rt.discrepancy.diagnose.campaign", "load_campaign": "frictionrt.rt.discrepancy.diagnose.campaign",
    "fit_in_parallel": "frictionrt.rt.discrepancy.diagnose.watch", "public": "frictionrt.rt.discrepancy.diagnose.campaign",
    "summary": "frictionrt.rt.discrepancy.diagnose.campaign",
    "diagnose_frf": "frictionrt.rt.discrepancy.diagnose.frf", "is_frf_folder": "frictionrt.rt.discrepancy.diagnose.frf",
    "diagnose_levels": "frictionrt.rt.discrepancy.diagnose.levels", "write_levels_report": "frictionrt.rt.discrepancy.diagnose.levels_report",
    "write_report": "frictionrt.rt.discrepancy.diagnose.report",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
