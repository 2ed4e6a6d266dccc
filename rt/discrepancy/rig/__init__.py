"""The virtual test rig (``frictionrt rig``): a "true" structure that differs from the nominal
model by parameter scatter and, optionally, one hidden effect of the library, and the campaigns
it writes in the measurement format.

Modules: ``campaign`` (the true structure, the model-form truth and the time-series campaign of
impulse and actuator tests, MCAP), ``frf`` (FRF files of the stuck linear plant), ``levels``
(FRF files at several excitation levels from the nonlinear plant), ``stepsine`` (the step-sine
tests). Imports rt.discrepancy's shared modules (``effects``, ``chain``), never the diagnosis.
The names below are imported on first use (rt/common/face.py).
"""
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "make_campaign": "frictionrt.rt.discrepancy.rig.campaign", "model_form": "frictionrt.rt.discrepancy.rig.campaign",
    "model_form_parts": "frictionrt.rt.discrepancy.rig.campaign", "model_form_refine": "frictionrt.rt.discrepancy.rig.campaign",
    "MODEL_FORM_PARTS": "frictionrt.rt.discrepancy.rig.campaign",
    "true_structure": "frictionrt.rt.discrepancy.rig.campaign", "scatter_sets": "frictionrt.rt.discrepancy.rig.campaign",
    "new_folder": "frictionrt.rt.discrepancy.rig.campaign", "FN1_LEVELS_N": "frictionrt.rt.discrepancy.rig.campaign",
    "HAMMER_PEAK_N": "frictionrt.rt.discrepancy.rig.campaign", "HAMMER_CONTACT_S": "frictionrt.rt.discrepancy.rig.campaign",
    "make_frf_campaign": "frictionrt.rt.discrepancy.rig.frf", "sensor_points": "frictionrt.rt.discrepancy.rig.frf", "add_points": "frictionrt.rt.discrepancy.rig.frf",
    "make_level_campaign": "frictionrt.rt.discrepancy.rig.levels", "sweep_level": "frictionrt.rt.discrepancy.rig.levels",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
