"""The contact layout chosen from the model against the hand-graded one (docs/plant.md 6.7).

    python -m benchmarks.model_layout [--fn1 40 100] [--layouts hand model] [--no-threshold]
                                      [--save FILE.npz] [--set KEY=VALUE ...]
    python -m benchmarks.model_layout --cost [--steps N] [--set KEY=VALUE ...]
    python -m benchmarks.model_layout --stepsine A.json A_REF.json [B.json B_REF.json ...]

Per F_N1 level and layout (plant.interface.layout) the simulated hammer test (plant.impulse) runs
at the configuration's discretisation and at its refined one (rt.common.config.refined_sets, factor
2: every spacing of the layout and the element length halved, four times the substeps; the model
layout's refined points hold its coarse ones, plant/layout.py). Each layout is measured against
its own refined model and against the other layout's, by plant.measures over modes 2-5 of the
reference: the peak's frequency [%] and height [dB], the half-power and the fitted damping [%],
the magnitude-weighted FRF error per mode band and over 50-1200 Hz [dB] and the rms of dB. A
damping figure counts against the 10 % tolerance only where the reference is off its slip threshold
(plant.measures.is_off_threshold: the refined model's zeta at the hammer force x (1 -+ 0.1));
--no-threshold skips those four extra runs per level.

--cost: per layout, the plant step's in-kernel time on ``frictionrt bench``'s input (a 5 N sine at the
stuck mode 3) in alternating rounds, median and p99.9 [us], with the load average beside them;
with --dump DIR the built models are pickled there for an instruction count under valgrind
(--count MODEL.pkl STEPS runs one of them STEPS steps: callgrind's total at 2 N minus that at N,
over N, is the step's count).

--stepsine: the step-sine peak heights of ``frictionrt reproduce --quick --json`` runs, each
layout's against its reference, per law, mode and amplitude [dB].
"""
from __future__ import annotations

import argparse
import json
import os
import pickle
import time

import numpy as np

from benchmarks.entry import run_main
from benchmarks.joint_convergence import hammer
from frictionrt.plant import measures
from frictionrt.rt.common.config import LAYOUTS, Config, load, refined_sets, with_sets

THRESHOLD_STEP = measures.FORCE_STEP


def layout_config(base: Config, layout: str, refined: bool) -> Config:
    """``base`` with plant.interface.layout = layout, refined by 2 if asked."""
    cfg = with_sets(base, [f"plant.interface.layout={layout}"])
    return with_sets(cfg, refined_sets(cfg, 2)) if refined else cfg


def compare(row: dict, ref: dict, off: list[bool] | None) -> dict:
    """``row``'s figures against ``ref`` in the bands of ref's modes 2-5 (module docstring)."""
    bands = measures.mode_bands(ref["f"])
    m = measures.mode_measures(row["freq"], row["H"], bands, row["tau_w"])
    m_ref = measures.mode_measures(ref["freq"], ref["H"], bands, ref["tau_w"])
    return {"df_pct": [100 * (a.f_peak_hz / b.f_peak_hz - 1) for a, b in zip(m, m_ref)],
            "dpeak_db": [20 * np.log10(a.peak_abs / b.peak_abs) for a, b in zip(m, m_ref)],
            "dzeta_hp_pct": [100 * (a.zeta_half_power / b.zeta_half_power - 1) for a, b in zip(m, m_ref)],
            "dzeta_fit_pct": [100 * (a.zeta_fit / b.zeta_fit - 1) for a, b in zip(m, m_ref)],
            "zeta_fit_ref_pct": [100 * b.zeta_fit for b in m_ref],
            "off_threshold": off if off is not None else [None] * len(m),
            "band_db": measures.band_errors_db(row["freq"], row["H"], ref["H"], bands),
            "weighted_db": measures.weighted_error_db(row["H"], ref["H"]),
            "rms_db": measures.rms_db(row["H"], ref["H"])}


def off_threshold(cfg: Config, F_N1: float, ref: dict) -> list[bool]:
    """Per mode 2-5 of ``ref``: is the fitted zeta of ``cfg`` off its slip threshold at the hammer
    force (the hammer at (1 -+ THRESHOLD_STEP) times it, plant.measures.is_off_threshold)?"""
    peak = cfg.impulse.peak_N
    z = []
    for s in (1 - THRESHOLD_STEP, 1 + THRESHOLD_STEP):
        r = hammer(with_sets(cfg, [f"impulse.peak_N={peak * s!r}"]), F_N1)
        m = measures.mode_measures(r["freq"], r["H"], measures.mode_bands(ref["f"]), r["tau_w"])
        z.append([x.zeta_fit for x in m])
    return [measures.is_off_threshold(lo, hi) for lo, hi in zip(*z)]


def _fmt(xs, f):
    return ", ".join(f.format(x) for x in xs)


def print_rows(F_N1: float, rows: list[tuple[str, dict]]) -> None:
    print(f"\nF_N1 = {F_N1:g} N, modes 2-5 of the reference: peak f [%], peak height [dB], zeta fit [%] "
          "(* on the reference's slip threshold), zeta half power [%], band errors [dB], weighted / rms of dB "
          "over 50-1200 Hz [dB]\n")
    print("| layout against reference | peak f | peak height | zeta, fit | zeta, half power | band error | "
          "weighted / rms |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, c in rows:
        zf = ", ".join(f"{d:+.0f}{'*' if o is False else ''}" for d, o in zip(c["dzeta_fit_pct"], c["off_threshold"]))
        print(f"| {name} | {_fmt(c['df_pct'], '{:+.3f}')} | {_fmt(c['dpeak_db'], '{:+.2f}')} | {zf} | "
              f"{_fmt(c['dzeta_hp_pct'], '{:+.0f}')} | {_fmt(c['band_db'], '{:.1f}')} | "
              f"{c['weighted_db']:.1f} / {c['rms_db']:.2f} |")


def hammer_sweep(base: Config, levels: list[float], layouts: list[str], threshold: bool, save: str | None) -> dict:
    """The hammer tables of the module docstring; returns every comparison by level."""
    out, saved = {}, {}
    for F_N1 in levels:
        res, off = {}, {}
        for lay in layouts:
            for refined in (False, True):
                cfg = layout_config(base, lay, refined)
                res[lay, refined] = hammer(cfg, F_N1)
                n = len(res[lay, refined]["f"])
                print(f"F_N1 {F_N1:g} N, {lay}{' refined' if refined else ''} done "
                      f"({res[lay, refined]['wall_s']:.0f} s, {n} modes)", flush=True)
                key = f"{F_N1:g}N_{lay}{'_ref' if refined else ''}"
                saved |= {f"{key}_H": res[lay, refined]["H"], f"{key}_f": res[lay, refined]["f"]}
            if threshold:
                off[lay] = off_threshold(layout_config(base, lay, True), F_N1, res[lay, True])
        rows = []
        for lay in layouts:
            for ref_lay in layouts:
                rows.append((f"{lay} / {ref_lay} refined", compare(res[lay, False], res[ref_lay, True], off.get(ref_lay))))
        if len(layouts) == 2:
            a, b = layouts
            rows.append((f"{a} refined / {b} refined", compare(res[a, True], res[b, True], off.get(b))))
        print_rows(F_N1, rows)
        out[F_N1] = rows
    if save:
        np.savez(save, **saved)
    return out


def cost(base: Config, layouts: list[str], steps: int, rounds: int, dump: str | None) -> None:
    """Alternating A/B of the plant step per layout (module docstring, --cost)."""
    from frictionrt.plant.model import build_plant
    from frictionrt.plant.simulate import run
    from frictionrt.rt.loop.bench import _excitation
    models = {lay: build_plant(layout_config(base, lay, False)) for lay in layouts}
    for lay, model in models.items():
        F = _excitation(model, steps)
        run(model, F[:2000], model.structure.F_N1_initial)   # warm-up: load the cache, touch memory
        if dump:
            os.makedirs(dump, exist_ok=True)
            with open(os.path.join(dump, f"{lay}.pkl"), "wb") as fh:
                pickle.dump(model, fh)
    stats = {lay: [] for lay in layouts}
    for k in range(rounds):
        for lay in (layouts if k % 2 == 0 else layouts[::-1]):
            model = models[lay]
            _, _, ns = run(model, _excitation(model, steps), model.structure.F_N1_initial)
            stats[lay].append((np.median(ns) / 1e3, np.percentile(ns, 99.9) / 1e3))
    print(f"\nPlant step, {steps} steps x {rounds} alternating rounds, load average {os.getloadavg()[0]:.1f} "
          "(1 min) at the end: median over rounds of the round's median / p99.9 [us] (range of the medians)\n")
    print("| layout | points | closed at F_N1 | median [us] | p99.9 [us] |")
    print("| --- | --- | --- | --- | --- |")
    from frictionrt.plant.model import preloaded_pairs
    for lay in layouts:
        s = np.array(stats[lay])
        m = models[lay]
        print(f"| {lay} | {m.n_pairs} | {int(preloaded_pairs(m).sum())} | {np.median(s[:, 0]):.2f} "
              f"({s[:, 0].min():.2f}..{s[:, 0].max():.2f}) | {np.median(s[:, 1]):.1f} |")


def count(path: str, steps: int) -> None:
    """Run a pickled model ``steps`` steps on bench's input (for valgrind's instruction count)."""
    from frictionrt.plant.simulate import run
    from frictionrt.rt.loop.bench import _excitation
    with open(path, "rb") as fh:
        model = pickle.load(fh)
    run(model, _excitation(model, steps), model.structure.F_N1_initial)


def stepsine(paths: list[str]) -> None:
    """Peak heights of reproduce --quick --json pairs (run, reference) [dB] (module docstring)."""
    def peaks(path):
        with open(path) as fh:
            data = json.load(fh)
        return {(c["law"], c["mode"], c["amp_n"]): c["peak"] for c in _cells(data)}
    for run_path, ref_path in zip(paths[0::2], paths[1::2]):
        a, b = peaks(run_path), peaks(ref_path)
        print(f"\n{run_path} against {ref_path}: peak |H| [dB]\n")
        print("| law | mode | amplitude [N] | peak [dB] |")
        print("| --- | --- | --- | --- |")
        worst = 0.0
        for k in sorted(a):
            if k in b:
                d = 20 * np.log10(a[k] / b[k])
                worst = max(worst, abs(d))
                print(f"| {k[0]} | {k[1]} | {k[2]:g} | {d:+.2f} |")
        print(f"largest |difference| {worst:.2f} dB")


def _cells(data: dict) -> list[dict]:
    """The peak cells of a reproduce --json output (its first estimator; the passive law's cells are
    the same under every estimator): law, mode, amp_n, peak |H| [(m/s^2)/N]."""
    v = next(iter(data["by_estimator"].values()))
    return [{"law": law, "mode": int(m), "amp_n": float(a), "peak": p["H_abs"]}
            for law, by_mode in v["peaks"].items() for m, by_amp in by_mode.items() for a, p in by_amp.items()]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fn1", type=float, nargs="+", default=[40.0, 100.0], help="F_N1 levels [N] (default 40 100)")
    ap.add_argument("--layouts", nargs="+", default=["hand", "model"], choices=list(LAYOUTS))
    ap.add_argument("--no-threshold", action="store_true", help="skip the slip-threshold runs of the references")
    ap.add_argument("--save", metavar="FILE.npz", help="also write every FRF (numpy .npz)")
    ap.add_argument("--cost", action="store_true", help="the plant step's A/B per layout instead")
    ap.add_argument("--steps", type=int, default=21000)
    ap.add_argument("--rounds", type=int, default=6)
    ap.add_argument("--dump", metavar="DIR", help="--cost: pickle the built models here")
    ap.add_argument("--count", nargs=2, metavar=("MODEL.pkl", "STEPS"))
    ap.add_argument("--stepsine", nargs="+", metavar="JSON")
    ap.add_argument("--set", action="append", default=[], dest="sets", metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    if args.count:
        count(args.count[0], int(args.count[1]))
        return 0
    if args.stepsine:
        if len(args.stepsine) % 2:
            raise SystemExit("--stepsine: give pairs RUN.json REFERENCE.json")
        stepsine(args.stepsine)
        return 0
    base = load(None, args.sets)
    t0 = time.perf_counter()
    if args.cost:
        cost(base, args.layouts, args.steps, args.rounds, args.dump)
    else:
        hammer_sweep(base, args.fn1, args.layouts, not args.no_threshold, args.save)
    print(f"\n({time.perf_counter() - t0:.0f} s)")
    return 0


if __name__ == "__main__":
    run_main(main)
