"""Confusion table of the discrepancy workflow (docs/discrepancy.md): for every implemented effect
of rt.discrepancy.effects at its moderate (default) strength and at half of it (half its departure from the
nominal value: current_limit 1 A -> 0.65 A), and for no effect, a rig campaign (seed SEED) is
diagnosed; printed as a markdown table (hidden effect, strength, named effect, fitted strength and
its error, dBIC and RSS reduction of the best candidate, runner-up, structure FRF gap and actuator
NRMSE before -> after, the step-sine F_amp/drive gap where the campaign has step-sine tests,
seconds), then the confusion matrix: hidden effect (rows) against named
effect (columns), counts over seeds and strengths.

    .venv/bin/python -m benchmarks.discrepancy [SEED ...] [--record-s 1.0] [--effects A,B] [--jobs N] [--stepsine]
        [--model-form [PARTS] [--refine R]] [--frf-files]

--model-form: the truth of another model form (rig --model-form, rt.discrepancy.rig.model_form; PARTS
a comma-separated subset of mesh,pitch,substeps,damping,beams, default all; --refine R: its mesh,
pitch and substeps parts at element length and pitch / R, substeps x R^2, rig --refine); the
table then also gives the gap's budget (rt.discrepancy.diagnose.remainder: calibration / effect / remainder
shares of the excess RSS, and whether the remainder dominates). --frf-files: linear FRF-file campaigns
(rig --frf-files) of the structural effects they can show, diagnosed by rt.discrepancy.diagnose.frf.

Campaigns get step-sine tests (rig --stepsine) when the hidden effect shows only there
(channel "stepsine": shaker_interaction), or all of them with --stepsine (~10 s more each).
    (-m: benchmarks/plant.py would shadow the plant package)
"""
import argparse
import tempfile
import time
from collections import Counter
from pathlib import Path

from joblib import Parallel, delayed

from frictionrt.rt.discrepancy.diagnose import diagnose, diagnose_frf
from frictionrt.rt.discrepancy.effects import get, implemented
from frictionrt.rt.discrepancy.rig import make_campaign, make_frf_campaign, model_form_parts, model_form_refine


def case(seed: int, name: str, s: float | None, record_s: float, stepsine: bool, other_form: tuple[str, ...],
         frf_files: bool, refine: int | None = None) -> tuple[dict, float]:
    """(diagnose result, seconds) of one hidden case."""
    t0 = time.perf_counter()
    stepsine = stepsine or (name != "none" and get(name).channel == "stepsine")
    with tempfile.TemporaryDirectory() as d:
        if frf_files:
            make_frf_campaign(Path(d) / "c", name, s, seed=seed, other_form=other_form, refine=refine)
            r = diagnose_frf(Path(d) / "c")
        else:
            make_campaign(Path(d) / "c", name, s, seed=seed, record_s=record_s, stepsine=stepsine,
                          other_form=other_form, refine=refine)
            r = diagnose(Path(d) / "c")
    r.pop("_config"), r.pop("_plots")
    return r, time.perf_counter() - t0


def row(seed: int, name: str, s: float | None, r: dict, secs: float) -> str:
    top = r["ranking"][0]
    named = r["named_effect"]
    fitted = ""
    if named:
        v = r["fitted_parameters"][named]
        fitted = f"{v:.4g}" + (f" ({100 * (v - s) / (s - get(name).nominal):+.1f} %)" if named == name else "")
    gb, ga = r["gap_before"], r["gap_after"]
    act = (f"{gb['actuator_nrmse']:.4f} -> {ga['actuator_nrmse']:.4f}" if gb.get("actuator_nrmse") is not None else "")
    ss = f"{gb['stepsine_ratio_db']:.2f} -> {ga['stepsine_ratio_db']:.2f}" if "stepsine_ratio_db" in gb else ""
    own = next((c for c in r["ranking"] if c["effect"] == name), None)
    own = "" if own is None else (f"{own['fitted'][name]:.4g}: {own['delta_bic']:.1f}, "
                                  f"{100 * own['rss_reduction']:.1f} %")
    fp = r["fitted_parameters"]
    cal = " / ".join(f"{fp[k]:.3g}" for k in ("E", "k_t", "mu", "modal_damping", "dispersion") if k in fp)
    b = r["gap_budget"]
    shares = ("" if b["remainder_share"] is None else
              f"{100 * b['calibration_share']:.0f} / {100 * b['effect_share']:.0f} / {100 * b['remainder_share']:.0f}"
              + (" dominates" if b["remainder_dominates"] else ""))
    return (f"| {seed} | {name} | {'' if s is None else f'{s:g}'} | {named or '-'} | {fitted} | "
            f"{top['effect']}: {top['delta_bic']:.1f}, {100 * top['rss_reduction']:.1f} % | {own} | {cal} | "
            f"{r['runner_up']} | "
            f"{gb['structure_frf_db']:.2f} -> {ga['structure_frf_db']:.2f} | {act} | {ss} | {shares} | {secs:.0f} |")


def matrix(hidden: list[str], named: Counter) -> str:
    cols = [n for n in hidden if n != "none"] + ["none"]
    lines = ["| hidden \\ named | " + " | ".join(cols) + " |", "| --- |" + " --- |" * len(cols)]
    for h in hidden:
        lines.append(f"| {h} | " + " | ".join(str(named[h, c]) if named[h, c] else "" for c in cols) + " |")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("seeds", type=int, nargs="*", default=[11])
    ap.add_argument("--record-s", type=float, default=1.0)
    ap.add_argument("--effects", help="comma-separated effect names (default: every implemented effect)")
    ap.add_argument("--jobs", type=int, default=1, help="campaigns diagnosed in parallel processes")
    ap.add_argument("--stepsine", action="store_true", help="step-sine tests in every campaign")
    ap.add_argument("--model-form", nargs="?", const="all", metavar="PARTS",
                    help="the truth of another model form (rig --model-form): all, or a comma-separated subset of "
                    "mesh,pitch,substeps,damping,beams")
    ap.add_argument("--refine", metavar="R", help="with --model-form: its mesh, pitch and substeps parts refined by R "
                    "(rig --refine)")
    ap.add_argument("--frf-files", action="store_true", help="linear FRF-file campaigns (rig --frf-files)")
    args = ap.parse_args()
    try:
        form = model_form_parts(args.model_form)
    except ValueError as exc:
        ap.error(f"--model-form: {exc}")
    if args.refine is not None and not form:
        ap.error(f"--refine {args.refine}: add --model-form")
    try:
        refine = model_form_refine(args.refine, form)
    except ValueError as exc:
        ap.error(f"--refine: {exc}")
    effects = [get(n) for n in args.effects.split(",")] if args.effects else implemented()
    if args.frf_files:
        effects = [e for e in effects if e.visible_in_frf_files()]
    cases = [("none", None)] + [(e.name, e.nominal + f * (e.parameter.default - e.nominal))
                                for e in effects for f in (1.0, 0.5)]
    print("| seed | hidden effect | strength | named | fitted (error) | best: dBIC, RSS reduction | "
          "hidden effect's own fit: strength, dBIC, RSS reduction | E / k_t / mu / damping / dispersion | runner-up | "
          "FRF gap [dB] before -> after | actuator NRMSE before -> after | step-sine F_amp/drive gap [dB] | "
          "calibration / effect / remainder [%] | s |")
    print("| --- |" + " --- |" * 13, flush=True)
    todo = [(seed, name, s) for seed in args.seeds for name, s in cases]
    named = Counter()
    runs = Parallel(n_jobs=args.jobs, return_as="generator")(delayed(case)(*c, args.record_s, args.stepsine,
                                                                            form, args.frf_files, refine)
                                                              for c in todo)
    for (seed, name, s), (r, secs) in zip(todo, runs):
        print(row(seed, name, s, r, secs), flush=True)
        named[name, r["named_effect"] or "none"] += 1
    print()
    print(matrix(["none"] + [e.name for e in effects], named))


if __name__ == "__main__":
    main()
