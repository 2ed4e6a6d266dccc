"""The virtual test rig (``frictionrt rig``): a "true" structure that differs from the nominal
model by parameter scatter and, optionally, one hidden effect of the library, and the campaigns
it writes in the measurement format.

Modules: ``campaign`` (the true structure, the model-form truth and the time-series campaign of
impulse and actuator tests, MCAP), ``frf`` (FRF files of the stuck linear plant), ``levels``
(FRF files at several excitation levels from the nonlinear plant), ``stepsine`` (the step-sine
tests). Imports rt.discrepancy's shared modules (``effects``, ``chain``), never the diagnosis.
The names below are imported on first use (rt/common/face.py).
"""
from rt.common.face import lazy_face

_EXPORTS = {
    "make_campaign": "rt.discrepancy.rig.campaign", "model_form": "rt.discrepancy.rig.campaign",
    "model_form_parts": "rt.discrepancy.rig.campaign", "model_form_refine": "rt.discrepancy.rig.campaign",
    "MODEL_FORM_PARTS": "rt.discrepancy.rig.campaign",
    "true_structure": "rt.discrepancy.rig.campaign", "scatter_sets": "rt.discrepancy.rig.campaign",
    "new_folder": "rt.discrepancy.rig.campaign", "FN1_LEVELS_N": "rt.discrepancy.rig.campaign",
    "HAMMER_PEAK_N": "rt.discrepancy.rig.campaign", "HAMMER_CONTACT_S": "rt.discrepancy.rig.campaign",
    "make_frf_campaign": "rt.discrepancy.rig.frf", "sensor_points": "rt.discrepancy.rig.frf", "add_points": "rt.discrepancy.rig.frf",
    "make_level_campaign": "rt.discrepancy.rig.levels", "sweep_level": "rt.discrepancy.rig.levels",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
