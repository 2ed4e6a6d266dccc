"""Which plausible values of the uncertain plant inputs change the reproduction's verdicts (issue 15)?

    python -m benchmarks.sensitivity [--full] [--only NAME ...] [--out DIR] [--jobs 2] [--set KEY=VALUE ...]
                                     [--estimator observer|oracle]

One at a time, each input of ``VARIANTS`` at a low and a high plausible value (the reason for the
range is the variant's ``why``), everything else at the configuration (``--set`` changes the base
for all runs, the default among them): the reproduction of ``frictionrt reproduce --quick`` (the
full one with ``--full``) through ``frictionrt.rt.experiments.reproduce.measure``, the controlled laws on the
paper's observer (``--estimator``), the claims C1..C6 (rt.experiments.claims) and the
peak reductions [dB]. The contact calibration (k_n, docs/plant.md 6) is not redone for a variant;
each row reports the impulse test's mode-3 frequency and damping at F_N1 = 100 N, so one sees
whether the variant still meets the paper's observation (215..235 Hz).

Writes into ``--out`` (default logs/sensitivity): ``sensitivity.json`` (per variant: the --set
assignments, claims with their numbers, peak_change_db, impulse, plan, wall time; rewritten after
every run) and ``sensitivity.md`` (verdict table, changed verdicts in bold, and the largest change
of a peak reduction against the default).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import NamedTuple

from benchmarks.report_diff import cells
from frictionrt.rt.experiments.claims import TOL_DB
from frictionrt.rt.common.config import load
from frictionrt.rt.experiments.reproduce import FULL, QUICK, measure
from frictionrt.rt.experiments.reproduce_report import jsonable
from benchmarks.entry import run_main


class Variant(NamedTuple):
    """One run: the input varied, its --set assignments and why the value is plausible."""
    name: str
    input: str
    sets: tuple[str, ...]
    why: str


def _both_screws(key: str, value: float) -> tuple[str, ...]:
    """--set assignments of key = value on the normal and the adaptive screw."""
    return tuple(f"plant.screws.{s}.{key}={value!r}" for s in ("normal", "adaptive"))


VARIANTS = (
    Variant("default", "-", (), "the configuration as it is"),
    Variant("mu_low", "mu", ("plant.interface.mu=0.25",),
            "dry steel on steel in bolted joints: 0.2-0.3 with oxide films or ground surfaces"),
    Variant("mu_high", "mu", ("plant.interface.mu=0.6",),
            "clean dry steel on steel: 0.5-0.6"),
    Variant("cone_small", "pressure law", _both_screws("head_diameter_m", 0.01163),
            "ISO 4017 M8 hex head, smallest bearing diameter d_w = 11.63 mm: cone radius 10.1 mm"),
    Variant("cone_large", "pressure law", _both_screws("head_diameter_m", 0.024),
            "DIN 9021 large washer (24 mm) under head and stack: cone radius 15.2 mm"),
    Variant("tau_low", "tau", ("plant.interface.tau_s=1e-6",),
            "contact modes (~14 kHz) at zeta = omega tau / 2 = 0.044; below, they ring (docs/plant.md 2.6)"),
    Variant("tau_high", "tau", ("plant.interface.tau_s=4e-6",),
            "zeta 0.18; above, the dashpots change the resonance response by > 6 % (docs/plant.md 2.6)"),
    Variant("bolt_soft", "bolt stiffness", ("plant.screws.normal.stiffness_N_m=2e8",),
            "VDI 2230 resilience of an M6 bolt or a longer grip: half the M8 value"),
    Variant("bolt_stiff", "bolt stiffness", ("plant.screws.normal.stiffness_N_m=8e8",),
            "an M10 bolt, or the head and thread stiffer than VDI's estimate: twice the M8 value"),
    Variant("stack_soft", "adaptive bolt stiffness", ("actuator.k_stack=1e7", "actuator.k_screw=1e7"),
            "stack and screw half as stiff: series 5e6 N/m (a long slender stack)"),
    Variant("stack_stiff", "adaptive bolt stiffness", ("actuator.k_stack=1e8", "actuator.k_screw=1e8"),
            "a 10 x 10 mm multilayer stack (~100 N/um) on a stiff screw: series 5e7 N/m"),
    Variant("F_min_low", "F_min", ("tracking.F_min_N=20.0", "tracking.F_passive_N=20.0"),
            "the stack's bias halved: the least force that keeps a preloaded stack in compression under the "
            "screw's own vibration (the passive reference moves with it)"),
    Variant("F_min_high", "F_min", ("tracking.F_min_N=80.0", "tracking.F_passive_N=80.0"),
            "twice the paper's 40 N: a stack preloaded to stay clear of tension at 20 N excitation"),
    Variant("screws_out", "screw positions", ("plant.screws.normal.x_m=0.47", "plant.screws.adaptive.x_m=0.62"),
            "5 mm from the damper's ends (SPEC: 10 mm, A): the least edge distance of an M8 head (6.5 mm radius) "
            "on the 8 mm beam"),
    Variant("screws_in", "screw positions", ("plant.screws.normal.x_m=0.485", "plant.screws.adaptive.x_m=0.605"),
            "20 mm from the ends: 2.5 bolt diameters, a usual edge distance for a bolted lap"),
)
CLAIMS = ("C2", "C3", "C4", "C5", "C6")


def run_variant(v: Variant, base_sets: list[str], full: bool, jobs: int | None, estimator: str) -> dict:
    """The reproduction of one variant, the controlled laws on ``estimator``: {name, input, sets,
    why, claims, peak_change_db, impulse, plan, wall_s}."""
    cfg = load(None, [*base_sets, *v.sets])
    t0 = time.perf_counter()
    rep = measure(cfg, FULL if full else QUICK, (estimator,), jobs=jobs,
                  stage=lambda text: print(f"sensitivity {v.name}: {text}", file=sys.stderr))["report"]
    return {"name": v.name, "input": v.input, "sets": list(v.sets), "why": v.why, "claims": rep["claims"],
            "peak_change_db": rep["peak_change_db"], "impulse": rep["impulse"], "plan": rep["plan"],
            "wall_s": time.perf_counter() - t0}


def markdown(doc: dict) -> str:
    """sensitivity.md: one row per variant, verdicts C2..C6 (bold where they differ from the
    default's), the impulse's mode 3 at F_N1 = 100 N, the largest |change| of a peak reduction
    against the default [dB] and where; then every peak reduction per variant."""
    runs = doc["runs"]
    ref = next((r for r in runs if r["name"] == "default"), None)
    lines = [(f"Plan: {doc['plan']}; the laws on the {doc['estimator']}; base --set: {doc['base_sets'] or 'none'}; "
              "a verdict in **bold** differs "
              "from the default's."), "",
             "| variant | input | --set | why plausible | mode 3 at 100 N [Hz], zeta [%] | " + " | ".join(CLAIMS)
             + " | largest change of a peak reduction [dB] |",
             "| --- " * (6 + len(CLAIMS)) + "|"]
    for r in runs:
        imp = r["impulse"]
        i3 = imp["modes"].index(3)
        f3 = f"{imp['freq_hz'][i3]:.1f}, {100 * imp['zeta']['3']:.3f}"
        verdicts = []
        for c in CLAIMS:
            text = "yes" if r["claims"][c]["holds"] else "NO"
            changed = ref is not None and r["claims"][c]["holds"] != ref["claims"][c]["holds"]
            verdicts.append(f"**{text}**" if changed else text)
        if ref is None or r is ref:
            delta = "-"
        else:
            a, b = cells(r["peak_change_db"]), cells(ref["peak_change_db"])
            key = max(a, key=lambda k: abs(a[k] - b[k]) if a[k] is not None and b.get(k) is not None else -1.0)
            delta = f"{a[key] - b[key]:+.2f} ({key[0]}, mode {key[1]}, {key[2]:g} N)"
        sets = "<br>".join(f"`{s}`" for s in r["sets"]) or "-"
        lines.append(f"| {r['name']} | {r['input']} | {sets} | {r['why']} | {f3} | " + " | ".join(verdicts)
                     + f" | {delta} |")
    lines += ["", ("What the verdicts were decided on (rt.experiments.claims): C2 zeta_passive / zeta_bare per mode; C3 the "
                   f"modes each law reduces by more than {TOL_DB} dB at every amplitude (2 needed); C4 each law's "
                   f"worst reduction at the smallest amplitude (<= +{TOL_DB} dB needed); C5 the mean advantage of "
                   "Lyapunov per amplitude [dB]; C6 the smallest Lyapunov / hysteresis power ratio at a peak "
                   "(> 1 needed):"), "",
              "| variant | C2 ratio | C3 modes reduced | C4 worst [dB] | C5 mean advantage [dB] | C6 min ratio |",
              "| --- | --- | --- | --- | --- | --- |"]
    for r in runs:
        n = {c: r["claims"][c]["numbers"] for c in CLAIMS}
        fmt = lambda d: ", ".join(f"{k}: {v:.3g}" if isinstance(v, float) else f"{k}: {v}" for k, v in d.items())
        c6 = n["C6"]["min_ratio_lyapunov_to_hysteresis"]
        lines.append(f"| {r['name']} | {fmt(n['C2']['ratio'])} | {fmt(n['C3']['modes_reduced'])} | "
                     f"{fmt(n['C4']['worst_peak_change_db'])} | {fmt(n['C5']['mean_advantage_db'])} | "
                     f"{'-' if c6 is None else f'{c6:.3g}'} |")
    lines += ["", (f"Peak reduction against passive [dB] (negative: lower peak; |x| < {TOL_DB} dB counts as "
                   "unchanged):"), ""]
    keys = sorted(cells(runs[0]["peak_change_db"])) if runs else []
    lines.append("| variant | " + " | ".join(f"{law[:4]} {m}/{a:g} N" for law, m, a in keys) + " |")
    lines.append("| --- " * (1 + len(keys)) + "|")
    for r in runs:
        c = cells(r["peak_change_db"])
        lines.append(f"| {r['name']} | " + " | ".join(f"{c[k]:+.2f}" if c.get(k) is not None else "-"
                                                     for k in keys) + " |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--full", action="store_true", help="the full reproduction per variant (default: --quick's plan)")
    ap.add_argument("--only", nargs="+", metavar="NAME", choices=[v.name for v in VARIANTS],
                    help="run these variants only (default: all, the default first)")
    ap.add_argument("--out", default="logs/sensitivity", help="folder for sensitivity.json and sensitivity.md")
    ap.add_argument("--jobs", type=int, default=None, help="local worker processes (default: the cores)")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE",
                    help="change the base configuration of every run")
    ap.add_argument("--estimator", choices=["observer", "oracle"], default="observer",
                    help="what the controlled laws run on (default: the paper's observer)")
    args = ap.parse_args(argv)
    variants = [v for v in VARIANTS if args.only is None or v.name in args.only]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    doc = {"plan": "full" if args.full else "quick", "base_sets": args.sets, "estimator": args.estimator, "runs": []}
    for v in variants:
        doc["runs"].append(jsonable(run_variant(v, args.sets, args.full, args.jobs, args.estimator)))
        (out / "sensitivity.json").write_text(json.dumps(doc, indent=1))
        (out / "sensitivity.md").write_text(markdown(doc))
        r = doc["runs"][-1]
        print(f"{v.name:>14}: " + " ".join(f"{c} {'yes' if r['claims'][c]['holds'] else 'NO'}" for c in CLAIMS)
              + f"  ({r['wall_s']:.0f} s)", flush=True)
    print(f"written: {out / 'sensitivity.json'}, {out / 'sensitivity.md'}")
    return 0


if __name__ == "__main__":
    run_main(main)
