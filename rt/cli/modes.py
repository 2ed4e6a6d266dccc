"""``frictionrt modes``: eigenfrequencies [Hz] of the bare beam and of the assembly, full and reduced."""
from __future__ import annotations

import argparse

from frictionrt.rt.cli.structure import add_structure, structure_modes


def add_parser(sub, parents) -> argparse.ArgumentParser:
    """Register ``modes`` (parents: frictionrt's --config/--set parser)."""
    m = sub.add_parser("modes", parents=parents, help="eigenfrequencies [Hz]: bare beam, full and reduced model",
                       description="Eigenfrequencies [Hz] of the bare main beam, and of the assembly with the "
                                   "contact linearised as stuck: full FE and Craig-Bampton model; DOF counts; "
                                   "the effective tangential stiffness k_T [N/m] at the adaptive screw (if the "
                                   "structure has one; docs/plant.md 5.3).")
    m.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    add_structure(m)
    return m


def cmd_modes(cfg, args) -> int:
    if args.structure:
        return structure_modes(cfg, args)
    from frictionrt.jobs import modes
    res = modes(cfg)
    print(res.to_json() if args.json else str(res))
    return 0

