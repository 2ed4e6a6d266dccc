"""The controller as C for a real-time target (docs/export-c.md): the controller's design record
and hash, the C99 export from templates, its build and the back-to-back replay against a log.

Modules: ``record`` (the numbers the C reads, ``design_hash``), ``generate`` (``export_c``: the
folder), ``cbuild`` (the compiler, a shared library through ctypes), ``replay_c`` (a log's
sensor stream through the compiled C, compared bit for bit), ``bench`` (``bench controller``),
``sil`` (the C as the numba loop's controller). The names below are imported on
first use (rt/common/face.py).
"""
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "controller_record": "frictionrt.rt.export.record", "design_hash": "frictionrt.rt.export.record",
    "export_c": "frictionrt.rt.export.generate", "read_manifest": "frictionrt.rt.export.generate",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
