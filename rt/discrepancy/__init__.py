"""The discrepancy workflow: the effects library, the virtual rig (the hidden truth) and the
diagnosis (the model side); both go through the same measurement chain.

Modules: ``effects`` (the library), ``chain`` (plant -> sensors, shared), ``rig``,
``rig_frf``, ``rig_stepsine`` (campaigns), ``diagnose`` (MCAP campaigns), ``diagnose_structure``
(the structural fit), ``diagnose_frf`` (FRF files), ``diagnose_stepsine`` (step-sine files and
the shaker), ``diagnose_report``, ``diagnose_rrd`` (the report and its rerun file). A
verb-named function lives in its module (``rt.discrepancy.diagnose.diagnose``). The names below
are imported on first use (rt/common/face.py).
"""
from rt.common.face import lazy_face

_EXPORTS = {
    "EFFECTS": "rt.discrepancy.effects", "Effect": "rt.discrepancy.effects", "implemented": "rt.discrepancy.effects",
    "measure_impulse": "rt.discrepancy.chain", "measure_actuator": "rt.discrepancy.chain", "quiet": "rt.discrepancy.chain", "scaled": "rt.discrepancy.chain", "hold_voltage": "rt.discrepancy.chain",
    "make_campaign": "rt.discrepancy.rig",
    "make_frf_campaign": "rt.discrepancy.rig_frf",
    "write_report": "rt.discrepancy.diagnose_report",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
