"""Outputs of ``frictionrt reproduce``: fig5.png, fig7.png, fig8.png, report.md, report.json.

``write_outputs`` writes them into a fresh folder next to the target and renames it onto the
target only when every file is complete, so a failed or interrupted run never leaves a half-written
report (a previous report at the target is replaced as a whole).
"""
from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from frictionrt.rt.experiments.branches import sweeps_line
from frictionrt.rt.experiments.claims import TOL_DB

CLAIM_TEXT = {
    "C1": "bare structure damping < 0.15 %",
    "C2": "the passive damper adds significant damping to modes 3, 4 and higher, little to mode 2",
    "C3": "both laws reduce the resonance peaks of several modes",
    "C4": "control never does worse than passive at low amplitudes",
    "C5": "Lyapunov reduces more than hysteresis-optimal, especially at small amplitudes",
    "C6": "Lyapunov needs more actuator power",
}


def jsonable(obj):
    """Plain JSON: dict keys as text (numbers with %g), numpy scalars as Python numbers,
    non-finite floats as None."""
    if isinstance(obj, dict):
        return {(f"{k:g}" if isinstance(k, float) else str(k)): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    return obj


def _fmt(v) -> str:
    """A number or a nested dict of numbers, short."""
    if isinstance(v, dict):
        return ", ".join(f"{k}: {_fmt(x)}" for k, x in v.items())
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, float):
        return f"{v:.3g}"
    if isinstance(v, list):
        return "[" + ", ".join(_fmt(x) for x in v) + "]"
    return str(v)


def _margin_cell(x: dict) -> str:
    """'**verdict** (margin M unit, shift S)' of one claim's result."""
    v = x.get("verdict", "yes" if x["holds"] else "NO")
    m, unit = x.get("margin"), x.get("margin_unit") or ""
    if m is None:
        return f"**{v}** (model input)" if x.get("margin_unit", 1) is None else f"**{v}**"
    shift = x.get("refined_shift")
    return (f"**{v}** (margin {m:+.3g} {unit}, discretisation {'not estimated' if shift is None else f'{shift:+.3g}'})")


def _claims_tables(r: dict) -> list[str]:
    """The verdicts of every estimator side by side, then each estimator's numbers."""
    by_est = r["by_estimator"]
    disc = r.get("discretisation") or {}
    lines = ["## Claims", "", f"Decided on the {next(iter(by_est))}; each estimator's verdict side by side. Each "
             "claim's margin is in its own unit (rt/experiments/claims.py; > 0: holds); \"discretisation\" is the "
             "estimated shift of the margin under a refined plant (C2: the impulse test on the refined plant itself; "
             f"C3-C6: Richardson from this run and the same plan with the contact pitch and the elements "
             f"x{disc.get('coarsening', 2):g}, order {disc.get('order', 1):g}"
             + (f", plus the same plan with the substeps x2, order {disc.get('step_order', 1):g}"
                if disc.get("half_step_margins") else "")
             + f"; margins: {disc.get('source', 'none')}); "
             "**undecided** where it is at least the margin "
             "(docs/experiments.md).", "",
             "| claim | statement | " + " | ".join(f"{e}" for e in by_est) + " |",
             "| --- | --- |" + " --- |" * len(by_est)]
    for c in r["claims"]:
        lines.append(f"| {c} | {CLAIM_TEXT[c]} | " + " | ".join(
            _margin_cell(v["claims"][c]) for v in by_est.values()) + " |")
    mech = r.get("mechanisms") or []
    if mech:
        lines += ["", "### Why a claim fails: the measured mechanism of each failing cell", "",
                  "Each cell run once more at its peak (rt/experiments/mechanisms.py): u0 the RT1 amplitude, K_f u0 / "
                  "F_min < 1: the hysteresis law saturates at F_min; 2f: the law's switching at twice the excitation "
                  "frequency, F_set and what reaches F_N1; the peak beside the passive peak at a constant F_N1 equal "
                  "to the law's mean.", "",
                  "| claim | estimator | law | mode | F [N] | reduction [dB] | u0 [um] | K_f u0 / F_min | "
                  "mean F_set / F_N1 [N] | at F_max | 2f: F_set / F_N1 [N] | peak / constant clamp |",
                  "| --- " * 12 + "|"]
        for x in mech:
            kf = f"{x['Kf_u0_over_Fmin']:.2f}" if x["law"] == "hysteresis" else "-"
            lines.append(f"| {x['claim']} | {x['estimator']} | {x['law']} | {x['mode']} | {x['amp']} | "
                         f"{x['reduction_db']:+.2f} | {x['u0_um']:.3f} | {kf} | {x['F_set_mean_n']:.0f} / "
                         f"{x['F_N1_mean_n']:.0f} | {x['at_F_max']:.2f} | {x['F_set_2f_n']:.1f} / {x['F_N1_2f_n']:.1f} | "
                         f"{x['peak']:.3g} / {x['constant_clamp_peak']:.3g} |")
    for e, v in by_est.items():
        lines += ["", f"### The numbers, laws on the {e}", "", "| claim | holds | numbers |", "| --- | --- | --- |"]
        for c, x in v["claims"].items():
            nums = "; ".join(f"{k}: {_fmt(y)}" for k, y in x["numbers"].items())
            note = f" ({x['note']})" if "note" in x else ""
            lines.append(f"| {c} | {'yes' if x['holds'] else 'NO'} | {nums}{note} |")
    return lines


def markdown(report: dict) -> str:
    """report.md: claims table, peak change, best constant F_N1, energy, impulse, plan, timing;
    each controlled law's figures per estimator side by side (report["by_estimator"])."""
    r = jsonable(report)
    plan, by_est = r["plan"], r["by_estimator"]
    ests = list(by_est)
    per = " / ".join(ests)
    lines = ["# frictionrt reproduce: Becker & Gaul's claims C1..C6 (SPEC section 6)", "",
             f"Modes {plan['modes']}, excitation force amplitudes {plan['amps_n']} N, the controlled laws on the "
             f"{' and the '.join(ests)}; {plan['points']} step-sine points ({plan['unsettled']} not settled), "
             f"{plan['simulated_s']:.0f} s simulated. Peaks are the largest measured |H| = |a(0.45 m) / F_exc| "
             f"[(m/s^2)/N]; peak change = 20 log10(peak_law / peak_passive) [dB], negative: the law's peak is lower; passive: F_N1 = "
             f"{plan['fn1_n'][0]:g} N (F_min). How the numbers are measured: docs/experiments.md.", ""]
    lines += _claims_tables(r)
    amps = [f"{a:g}" for a in plan["amps_n"]]
    lines += ["", "## Peak change against passive [dB] (negative: lower)", "",
              f"Negative: the law's peak is lower. |x| < {TOL_DB:g} dB counts as unchanged (rt/experiments/claims.py). "
              f"Each cell: {per}.", "",
              "| law | mode | " + " | ".join(f"{a} N" for a in amps) + " |", "| --- | --- |" + " --- |" * len(amps)]
    for law, by_mode in r["peak_change_db"].items():
        for m in by_mode:
            lines.append(f"| {law} | {m} | " + " | ".join(
                " / ".join(f"{by_est[e]['peak_change_db'][law][m][a]:+.2f}" for e in ests) for a in amps) + " |")
    lines += ["", "## Resonance peaks", "",
              "| law | estimator | mode | amplitude [N] | peak |H| [(m/s^2)/N] | at [Hz] | acceleration [m/s^2] "
              "| mean F_N1 [N] | actuator power [W] | settled |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for e, v in by_est.items():
        for law, by_mode in v["peaks"].items():
            if law == "passive" and e != ests[0]:
                continue  # the passive law ignores the estimate: one run
            for m, by_amp in by_mode.items():
                for a, p in by_amp.items():
                    edge = " (band edge)" if p["at_band_edge"] else ""
                    lines.append(f"| {law} | {'-' if law == 'passive' else e} | {m} | {a} | {p['H_abs']:.4g} | "
                                 f"{p['f_hz']:.2f}{edge} | {p['acc_m_s2']:.4g} | {p['F_N1_mean_n']:.0f} | "
                                 f"{p['power_w']:.3g} | {'yes' if p['settled'] else 'NO'} |")
    lines += ["", "## Best constant F_N1 (the fair baseline)", "",
              f"Passive law at constant F_N1 in {plan['fn1_n']} N; vs best = 20 log10(peak_law / best constant "
              f"peak) [dB] (negative: the law beats every constant force tried); each law's cell: {per}.", "",
              "| mode | amplitude [N] | best F_N1 [N] | its peak | hysteresis peak (vs best) | Lyapunov peak (vs best) "
              "| peak per F_N1 |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for m, by_amp in r["best_passive_fn1"].items():
        for a, d in by_amp.items():
            each = ", ".join(f"{f} N: {p:.3g}" for f, p in d["peaks_by_fn1"].items())
            law_cells = [" / ".join(f"{by_est[e]['best_passive_fn1'][m][a][law]['H_abs']:.4g} "
                                    f"({by_est[e]['best_passive_fn1'][m][a][law]['vs_best_db']:+.2f} dB)" for e in ests)
                         for law in ("hysteresis", "lyapunov")]
            lines.append(f"| {m} | {a} | {d['fn1_n']:g} | {d['H_abs']:.4g} | {law_cells[0]} | {law_cells[1]} | {each} |")
    lines += ["", "## Actuator energy", "", "Over the measurement blocks of every step-sine point of the law.", "",
              "| law | estimator | energy [J] | measured time [s] | mean power [W] |", "| --- | --- | --- | --- | --- |"]
    for e, v in by_est.items():
        for law, x in v["energy"].items():
            if law != "passive" or e == ests[0]:
                lines.append(f"| {law} | {'-' if law == 'passive' else e} | {x['energy_j']:.4g} | "
                             f"{x['duration_s']:.3g} | {x['mean_power_w']:.3g} |")
    imp = r["impulse"]
    lines += ["", f"## Impulse test at F_N1 = {imp['fn1_n']:g} N (fig5.png)", "",
              "| mode | f [Hz] | zeta [%] | bare zeta [%] (model input) |", "| --- | --- | --- | --- |"]
    for m, f in zip(imp["modes"], imp["freq_hz"]):
        z = imp["zeta"][str(m)]
        lines.append(f"| {m} | {f:.2f} | {'n/a' if z is None else f'{100 * z:.3f}'} | "
                     f"{100 * imp['zeta_bare'][str(m)]:.3f} |")
    lines += ["", f"Bare main beam bending modes [Hz]: {', '.join(f'{f:.1f}' for f in imp['bare_beam_hz'])}.", "",
              "## Run", "", f"Wall time [s]: impulse {r['timing_s']['impulse']:.3g}, step-sine "
              f"{r['timing_s']['step_sine']:.3g}; {sweeps_line(r['timing_s']['sweeps'])}. Step-sine detector: "
              f"{_fmt(plan['settle'])}; {plan['n_points']} coarse points per mode, up to {plan['refine_rounds']} "
              "refinement rounds.", ""]
    return "\n".join(lines)


def plot_laws(frfs_by_estimator: dict, law: str, path: str | None, title: str):
    """|H| [dB re 1 (m/s^2)/N] against f [Hz], one panel per mode: the law on the first estimator
    solid, on the others dotted, passive dashed (as the paper's Figs. 7, 8), one colour per
    amplitude; unsettled points hollow. PNG."""
    from matplotlib.figure import Figure
    ests = list(frfs_by_estimator)
    frfs = frfs_by_estimator[ests[0]]
    modes = sorted({k.mode for k in frfs})
    amps = sorted({k.amp_n for k in frfs})
    fig = Figure(figsize=(3.6 * len(modes), 4.2))
    axes = fig.subplots(1, len(modes), squeeze=False)
    for ax, m in zip(axes[0], modes):
        for c, a in enumerate(amps):
            curves = [("passive", "passive", "--", frfs)] + [
                (law, f"{law} ({e})", "-" if i == 0 else ":", frfs_by_estimator[e]) for i, e in enumerate(ests)]
            for name, label, style, view in curves:
                r = view[next(k for k in view if k.law == name and k.fn1_n is None and k.mode == m and k.amp_n == a)]
                db = 20 * np.log10(r.H_abs)
                ax.plot(r.freq_hz, db, style, color=f"C{c}", lw=1.0, marker=".", ms=3, label=f"{label}, {a:g} N")
                if not np.all(r.settled):
                    ax.plot(r.freq_hz[~r.settled], db[~r.settled], "o", mfc="none", color=f"C{c}", ms=6)
        ax.set_title(f"mode {m}")
        ax.set_xlabel("f [Hz]")
        ax.grid(True, lw=0.3)
    axes[0][0].set_ylabel("|a(0.45 m) / F_exc| [dB re 1 (m/s^2)/N]")
    axes[0][-1].legend(fontsize=6)
    others = f", dotted: on the {' and the '.join(ests[1:])}" if len(ests) > 1 else ""
    fig.suptitle(f"{title}\nsolid: controlled on the {ests[0]}{others}; dashed: passive F_N1 = F_min; "
                 "hollow: not settled", fontsize=9)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig


def write_outputs(out: Path, result: dict, f_max_hz: float) -> None:
    """fig5.png (impulse FRF), fig7.png (hysteresis vs passive), fig8.png (Lyapunov vs passive),
    report.md and report.json into out, all at once (module docstring)."""
    from frictionrt.plant.impulse import plot_frf
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        plot_frf(result["impulse"], str(tmp / "fig5.png"), f_max_hz)
        plot_laws(result["frfs_by_estimator"], "hysteresis", str(tmp / "fig7.png"), "Hysteresis-optimal vs passive")
        plot_laws(result["frfs_by_estimator"], "lyapunov", str(tmp / "fig8.png"), "Lyapunov vs passive")
        (tmp / "report.md").write_text(markdown(result["report"]))
        (tmp / "report.json").write_text(json.dumps(jsonable(result["report"]), indent=1))
        old = None
        if out.exists():
            old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old.", dir=out.parent))
            os.replace(out, old / out.name)
        os.replace(tmp, out)
        if old is not None:
            shutil.rmtree(old)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
