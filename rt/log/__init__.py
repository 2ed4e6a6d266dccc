"""Logs and measurements: MCAP and rrd files, the writer thread, the measurement format, FRF files,
the design record. Depends on rt.common only.

Modules: ``mcap_log`` (the MCAP format: topics, schemas, reading), ``registry`` (signal names
and their ROS 2 fields), ``writer`` (the writer thread draining the loop's ring), ``rrd_log``
(rerun), ``views`` (Foxglove layout, rerun blueprint), ``data_format`` (the measurement format
and its validator), ``frf_files`` (measured FRFs: CSV and UFF with sidecars), ``frf_import`` (FRFs as
analysers export them, into FRF files),
``design_record`` (the kernels' design arrays carried in a log), ``recover`` (a killed run's
``.mcap.part``). The names below are imported on first use (rt/common/face.py).
"""
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "McapLog": "frictionrt.rt.log.mcap_log", "McapLogWriter": "frictionrt.rt.log.mcap_log", "read_mcap": "frictionrt.rt.log.mcap_log", "FORMAT_VERSION": "frictionrt.rt.log.mcap_log",
    "McapBlockWriter": "frictionrt.rt.log.writer", "LogWriter": "frictionrt.rt.log.writer", "open_run_log": "frictionrt.rt.log.writer", "run_metadata": "frictionrt.rt.log.writer",
    "RrdLogWriter": "frictionrt.rt.log.rrd_log", "write_rrd": "frictionrt.rt.log.rrd_log", "mcap_to_rrd": "frictionrt.rt.log.rrd_log",
    "validate": "frictionrt.rt.log.data_format",
    "import_frf": "frictionrt.rt.log.frf_import", "ImportResult": "frictionrt.rt.log.frf_import",
    "FRFTest": "frictionrt.rt.log.frf_files", "read_frf": "frictionrt.rt.log.frf_files", "load_frf_folder": "frictionrt.rt.log.frf_files", "write_frf_csv": "frictionrt.rt.log.frf_files", "write_frf_uff": "frictionrt.rt.log.frf_files",
    "use_logged": "frictionrt.rt.log.design_record", "describe": "frictionrt.rt.log.design_record",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
