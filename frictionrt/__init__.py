"""frictionrt: real-time emulation of semi-actively controlled friction dampers (Becker & Gaul).

The packages: ``frictionrt.rt`` (the loop, logs, experiments, the discrepancy workflow, the
command line), ``frictionrt.plant``, ``frictionrt.observer`` and ``frictionrt.tracking``.
"""
