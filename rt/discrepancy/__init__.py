"""The discrepancy workflow: the effects library, the virtual rig (the hidden truth) and the
diagnosis (the model side); both go through the same measurement chain.

Sub-packages: ``rig`` (the virtual rig: the true structure and its campaigns) and ``diagnose``
(the diagnosis and its channels); ``diagnose`` imports ``rig``, never the reverse (the
import-linter contract in pyproject.toml). Shared modules: ``effects`` (the library), ``chain``
(plant -> sensors). The names below are imported on first use (rt/common/face.py).
"""
from rt.common.face import lazy_face

_EXPORTS = {
    "EFFECTS": "rt.discrepancy.effects", "Effect": "rt.discrepancy.effects", "implemented": "rt.discrepancy.effects",
    "measure_impulse": "rt.discrepancy.chain", "measure_actuator": "rt.discrepancy.chain", "quiet": "rt.discrepancy.chain", "scaled": "rt.discrepancy.chain", "hold_voltage": "rt.discrepancy.chain",
    "make_campaign": "rt.discrepancy.rig.campaign",
    "make_frf_campaign": "rt.discrepancy.rig.frf",
    "write_report": "rt.discrepancy.diagnose.report",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
