"""frictionrt: real-time emulation of semi-actively controlled friction dampers (Becker & Gaul).

The Python API, one function per job, each with the command line's defaults::

    import frictionrt as fr
    cfg = fr.load_config(sets=["tracking.K_f=8.2e9"])
    res = fr.simulate(cfg, law="hysteresis", freq_hz=223.6, amp_n=5.0, out="logs/hyst")
    res["acc045_amplitude"], res.to_dict(), res.plot()

Jobs: ``load_config``, ``show_config``, ``modes``, ``impulse``, ``simulate``, ``compare``, ``frf``,
``reproduce``, ``tune``, ``replay``, ``export_c``, ``effects``, ``rig``, ``diagnose``,
``diagnose_frf_arrays``, ``import_frf``. Each returns a ``Result`` (``.to_dict()`` is what the
command line's ``--json`` prints; ``.plot()`` a matplotlib Figure); ``tune`` its ``TuneResult``.
``Estimator.OBSERVER`` (the default), ``Estimator.ORACLE`` and ``Estimator.AMPLITUDE`` (the
observer with each mode's frequency following its amplitude) say what the laws run on.

The packages beneath: ``frictionrt.rt`` (loop, logs, experiments, the discrepancy workflow, the
command line), ``frictionrt.plant``, ``frictionrt.observer``, ``frictionrt.tracking``. Importing
frictionrt first fixes OpenBLAS's kernels and numba's code-generation target, so a run gives the
same bits on every machine (docs/determinism.md). The names are imported on first use.
"""
import frictionrt.rt.common  # noqa: F401  (BLAS, numba's target and cache, before numpy or a kernel loads)
from frictionrt.rt.common.face import lazy_face

_EXPORTS = {
    "load_config": "frictionrt.jobs",
    "show_config": "frictionrt.jobs",
    "modes": "frictionrt.jobs",
    "impulse": "frictionrt.jobs",
    "simulate": "frictionrt.jobs",
    "compare": "frictionrt.jobs",
    "frf": "frictionrt.jobs",
    "reproduce": "frictionrt.jobs",
    "tune": "frictionrt.jobs",
    "replay": "frictionrt.jobs",
    "export_c": "frictionrt.jobs",
    "effects": "frictionrt.jobs",
    "rig": "frictionrt.jobs",
    "diagnose": "frictionrt.jobs",
    "diagnose_frf_arrays": "frictionrt.jobs",
    "check_frequency": "frictionrt.jobs",
    "import_frf": "frictionrt.rt.log.frf_import",
    "Result": "frictionrt.results",
    "Config": "frictionrt.rt.common.config", "ConfigError": "frictionrt.rt.common.config",
    "Estimator": "frictionrt.rt.common.config", "ESTIMATORS": "frictionrt.rt.common.config",
    "DEFAULT_ESTIMATOR": "frictionrt.rt.common.config", "LAWS": "frictionrt.rt.common.config",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
