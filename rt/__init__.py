"""frictionrt's real-time side: the loop, logging, experiments, the discrepancy workflow, the CLI.

The rooms (docs/layout.md), each a sub-package whose ``__init__``
lists what the others may use:

- ``frictionrt.rt.common``: configuration, clock slots, noise, the kernels' code generation and cache
- ``frictionrt.rt.log``: MCAP / rrd logs, the writer thread, the measurement format, FRF files
- ``frictionrt.rt.loop``: the fixed-step loop (build, tick, pacing, driver), supervisor, replay, budget
- ``frictionrt.rt.experiments``: step-sine FRFs, the paper's reproduction and claims, tuning
- ``frictionrt.rt.discrepancy``: the virtual rig and the diagnosis
- ``frictionrt.rt.cli``: the ``frictionrt`` command, one module per verb

Importing any of them first runs ``frictionrt.rt.common`` (numba's target and cache directory are set
before a kernel compiles).
"""
import frictionrt.rt.common  # noqa: F401
