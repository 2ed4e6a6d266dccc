"""``--structure FILE``: the verbs on an imported structure (plant.superelement; docs/superelement.md).
Shared by those verbs; a verb calls the function for its own name."""
from __future__ import annotations

import argparse
import json

from frictionrt.plant.superelement import CLUSTERINGS, DEFAULT_CLUSTERING
from frictionrt.rt.cli.common import fail


NOT_ON_STRUCTURE = {
    "reproduce": "the paper's claims and their discretisation error (contact pitch and elements x2) are the "
                 "built-in beams'; on an imported structure use frf --around-modes and tune",
    "rig": "its effects are changes of the built-in beams' parameters, which an imported structure's matrices "
           "do not have",
    "diagnose": "its fits adjust the built-in beams' parameters, which an imported structure's matrices do not "
                "have; compare your FRFs with frf --structure",
}
"""Verbs that take --structure only to refuse it in one line (rt.cli.app), with what is missing."""


def refusal(verb: str) -> str:
    """The one line a verb of ``NOT_ON_STRUCTURE`` refuses --structure with."""
    return f"{verb} --structure: not on an imported structure: {NOT_ON_STRUCTURE[verb]}; drop --structure"


def structure_arg(args):
    """The ``rt.loop.structure.Structure`` of --structure/--clusters (None without --structure);
    ValueError (one line naming the file or the count) for a missing file or clusters < 0."""
    from frictionrt.rt.loop.structure import structure_of
    return None if not getattr(args, "structure", None) else structure_of(args.structure, args.clusters,
                                                                          args.clustering)


def add_structure(p: argparse.ArgumentParser) -> None:
    """--structure FILE and --clusters N (the interface coarsened to N points)."""
    p.add_argument("--structure", metavar="FILE", default=None,
                   help="an imported structure (a superelement: .npz, .mat v5/v7.3, Matrix Market manifest .json, "
                        ".op4; docs/superelement.md) instead of the configured beams; the interface's per-area "
                        "parameters, the step and the damping still come from the configuration")
    p.add_argument("--clusters", type=int, default=0, metavar="N",
                   help="with --structure: coarsen the interface to N contact points (node clustering); 0: as read")
    p.add_argument("--clustering", choices=CLUSTERINGS, default=DEFAULT_CLUSTERING,
                   help="with --clusters: group the points within the bolts' contact footprints (footprint: the "
                        "patches the adaptive bolt closes stay closed) or by k-means on their coordinates alone")


def _plant(cfg, args):
    """(plant, None) or (None, exit code) after a one-line error."""
    from frictionrt.plant.se_analysis import load_plant
    from frictionrt.plant.superelement import SuperelementError
    if args.clusters < 0:
        return None, fail(f"--clusters {args.clusters}: must be >= 0 (0: the interface as read)")
    try:
        return load_plant(args.structure, cfg, args.clusters, args.clustering), None
    except SuperelementError as e:
        return None, fail(f"--structure {args.structure}: {e}")
    except RuntimeError as e:
        return None, fail(f"--structure {args.structure}: {e}")


def _fn1(cfg, args, plant) -> float:
    v = getattr(args, "fn1", None)
    return plant.F_N1_initial if v is None else float(v)


def structure_modes(cfg, args) -> int:
    from frictionrt.plant.se_analysis import format_modes, modes_summary
    plant, rc = _plant(cfg, args)
    if plant is None:
        return rc
    s = modes_summary(plant)
    print(json.dumps(s) if args.json else format_modes(s))
    return 0


def structure_impulse(cfg, args) -> int:
    from frictionrt.plant.se_analysis import impulse
    if args.plot:
        return fail("-o with --structure: the FRF plot of an imported structure is not written yet; use --json")
    plant, rc = _plant(cfg, args)
    if plant is None:
        return rc
    try:
        r = impulse(plant, cfg, _fn1(cfg, args, plant))
    except (ValueError, RuntimeError) as e:
        return fail(f"--structure {args.structure}: {e}")
    if args.json:
        print(json.dumps(r))
        return 0
    print(f"impulse test, imported structure, F_N1 = {r['F_N1_N']:g} N, hammer {cfg.impulse.peak_N:g} N, "
          f"accelerance at {r['sensor']}")
    print(f"{'linear [Hz]':>11} {'f [Hz]':>9} {'zeta [%]':>9}")
    for fl, f, z in zip(r["linear_hz"], r["freq_hz"], r["damping_ratio"]):
        print(f"{fl:>11.2f} {f:>9.2f} {100 * z:>9.3f}")
    return 0


def structure_simulate(cfg, args) -> int:
    from frictionrt.plant.se_analysis import simulate
    if args.out or args.law not in (None, "passive") or args.paced or args.controller:
        return fail("--plant-only runs the imported plant alone with the passive joint (constant F_N1): drop "
                    "--out, --law, --paced and --controller (or --plant-only for the closed loop)")
    plant, rc = _plant(cfg, args)
    if plant is None:
        return rc
    try:
        r = simulate(plant, cfg, args.freq, args.amp, args.duration, plant.F_N1_initial)
    except (ValueError, RuntimeError) as e:
        return fail(f"--structure {args.structure}: {e}")
    print(json.dumps(r) if getattr(args, "json", False) else "\n".join(f"{k}: {v}" for k, v in r.items()))
    return 0
