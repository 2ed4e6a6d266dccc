"""The discrepancy workflow: the effects library, the virtual rig (the hidden truth) and the
diagnosis (the model side); both go through the same measurement chain.

Sub-packages: ``rig`` (the virtual rig: the true structure and its campaigns) and ``diagnose``
(the diagnosis and its channels); ``diagnose`` imports ``rig``, never the reverse (the
import-linter contract in pyproject.toml). Shared modules: ``effects`` (the library), ``chain``
(plant -> sensors). The names below are imported on first use (rt/common/face.py).
"""
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "EFFECTS": "frictionrt.rt.discrepancy.effects", "Effect": "frictionrt.rt.discrepancy.effects", "implemented": "frictionrt.rt.discrepancy.effects",
    "measure_impulse": "frictionrt.rt.discrepancy.chain", "measure_actuator": "frictionrt.rt.discrepancy.chain", "quiet": "frictionrt.rt.discrepancy.chain", "scaled": "frictionrt.rt.discrepancy.chain", "hold_voltage": "frictionrt.rt.discrepancy.chain",
    "make_campaign": "frictionrt.rt.discrepancy.rig.campaign",
    "make_frf_campaign": "frictionrt.rt.discrepancy.rig.frf",
    "write_report": "frictionrt.rt.discrepancy.diagnose.report",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
