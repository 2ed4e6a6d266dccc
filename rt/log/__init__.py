"""Logs and measurements: MCAP and rrd files, the writer thread, the measurement format, FRF files,
the design record. Depends on rt.common only.

Modules: ``mcap_log`` (the MCAP format: topics, schemas, reading), ``registry`` (signal names
and their ROS 2 fields), ``writer`` (the writer thread draining the loop's ring), ``rrd_log``
(rerun), ``views`` (Foxglove layout, rerun blueprint), ``data_format`` (the measurement format
and its validator), ``frf_files`` (measured FRFs: CSV and UFF with sidecars),
``design_record`` (the kernels' design arrays carried in a log), ``recover`` (a killed run's
``.mcap.part``). The names below are imported on first use (rt/common/face.py).
"""
from rt.common.face import lazy_face

_EXPORTS = {
    "McapLog": "rt.log.mcap_log", "McapLogWriter": "rt.log.mcap_log", "read_mcap": "rt.log.mcap_log", "FORMAT_VERSION": "rt.log.mcap_log",
    "McapBlockWriter": "rt.log.writer", "LogWriter": "rt.log.writer", "open_run_log": "rt.log.writer", "run_metadata": "rt.log.writer",
    "RrdLogWriter": "rt.log.rrd_log", "write_rrd": "rt.log.rrd_log", "mcap_to_rrd": "rt.log.rrd_log",
    "validate": "rt.log.data_format",
    "FRFTest": "rt.log.frf_files", "read_frf": "rt.log.frf_files", "load_frf_folder": "rt.log.frf_files", "write_frf_csv": "rt.log.frf_files", "write_frf_uff": "rt.log.frf_files",
    "use_logged": "rt.log.design_record", "describe": "rt.log.design_record",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
