"""The amplitude-dependence diagnosis' report (rt.discrepancy.diagnose.levels): the text the CLI prints,
diagnose.json, model.toml, report.md and levels.png (an interrupted diagnosis': rt.discrepancy.diagnose.watch).
Moved out of levels.py unchanged."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionrt.rt.discrepancy.diagnose.plausible import markdown, summary_lines
from frictionrt.rt.discrepancy.diagnose.watch import write_result


def summary(res: dict) -> str:
    """The text the CLI prints."""
    lines = [f"calibrated on {', '.join(f'{a:g}' for a in res['calibrate_on_n'])} {res['level_unit']} (harmonic balance: "
             f"{res['harmonic_method']}); softening mode "
             f"{res['softening_mode']} ({res['softening_band_hz'][0]:g}-{res['softening_band_hz'][1]:g} Hz)",
             f"named effect: {res['named_effect'] or 'no missing effect found'}",
             f"fitted (harmonic balance): {res['nonlinear']['fitted']}",
             *([f"note: {res['contact_note']}"] if res["contact_note"] else []),
             *[f"warning ({w['model']}): {w['parameter']} = {w['value']:g} at its bound {w['bound']:g}: {w['fix']}"
               for w in res["warnings"]],
             *summary_lines(res["plausibility"]),
             f"level [{res['level_unit']}]  calibrated  gap linear / harmonic balance [dB] (softening band; all lines)  "
             "ratio"]
    for p in res["prediction"]:
        lines.append(f"  {p['level_n']:>7g}  {'yes' if p['calibrated_on'] else 'no':>10}  "
                     f"{p['gap_linear_db']:.3f} / {p['gap_nonlinear_db']:.3f}  ({p['gap_linear_all_db']:.3f} / "
                     f"{p['gap_nonlinear_all_db']:.3f})  {p['ratio']}")
    return "\n".join(lines)


def write_levels_report(res: dict, out: str | Path) -> Path:
    """The report folder (a new folder, written beside and renamed: never half a report):
    diagnose.json, model.toml (the calibrated harmonic-balance model), report.md and levels.png
    (per level the measured |H| of the first sensor, the linear and the harmonic-balance prediction)."""
    import json

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from frictionrt.rt.discrepancy.rig.campaign import new_folder
    with new_folder(out) as tmp:
        write_result(tmp, res)
        plots = res["_plots"]
        fig, axes = plt.subplots(len(plots), 1, figsize=(8, 2.2 * len(plots)), sharex=True, squeeze=False)
        for ax, (name, a, f, H, h0, h1) in zip(axes[:, 0], plots):
            s = next(iter(H))
            ax.semilogy(f, np.abs(H[s]), "k.", ms=3, label=f"measured {s}")
            ax.semilogy(f, np.abs(h0[s]), "C1-", lw=0.8, label="linear (stuck)")
            ax.semilogy(f, np.abs(h1[s]), "C0-", lw=0.8, label="harmonic balance")
            ax.axvspan(*res["softening_band_hz"], color="0.9", zorder=0)
            cal = "calibrated on" if a in res["calibrate_on_n"] else "predicted"
            ax.set_title(f"{name}: {a:g} {res['level_unit']} ({cal})", fontsize=9)
            ax.grid(True, lw=0.3)
        axes[0, 0].legend(fontsize=7)
        axes[-1, 0].set_xlabel("f [Hz]")
        fig.tight_layout()
        fig.savefig(tmp / "levels.png", dpi=110)
        plt.close(fig)
        rows = [f"| {p['level_n']:g} | {'yes' if p['calibrated_on'] else 'no'} | {p['gap_linear_db']} | "
                f"{p['gap_nonlinear_db']} | {p['ratio']} | {p['gap_linear_all_db']} | {p['gap_nonlinear_all_db']} |"
                for p in res["prediction"]]
        (tmp / "report.md").write_text("\n".join([
            "# Amplitude dependence: calibrated at some levels, predicted at the others", "",
            f"Calibrated on {', '.join(f'{a:g}' for a in res['calibrate_on_n'])} {res['level_unit']}. Softening mode "
            f"{res['softening_mode']}, band {res['softening_band_hz'][0]:g}-{res['softening_band_hz'][1]:g} Hz "
            "(docs/discrepancy.md, \"Amplitude dependence\").", "",
            f"**Named effect: {res['named_effect'] or 'no missing effect found'}**", "",
            f"Harmonic balance: method {res['harmonic_method']}." + (f" Note: {res['contact_note']}." if res["contact_note"]
                                                                     else ""), "",
            f"Harmonic-balance calibration: `{json.dumps(res['nonlinear']['fitted'])}`; linear: "
            f"`{json.dumps(res['linear']['fitted'])}`.", "",
            f"| level [{res['level_unit']}] | calibrated on | gap linear [dB] | gap harmonic balance [dB] | ratio | linear, all lines | "
            "harmonic balance, all lines |", "| --- | --- | --- | --- | --- | --- | --- |", *rows, "",
            *(["", "## Warnings: parameters on a bound", "", "| model | parameter | value | bound | fix |",
               "| --- | --- | --- | --- | --- |"]
              + [f"| {w['model']} | {w['parameter']} | {w['value']:g} | {w['bound']:g} | {w['fix']} |"
                 for w in res["warnings"]] if res["warnings"] else []), "",
            *markdown(res["plausibility"]), "",
            "![levels.png](levels.png)", ""]))
    return Path(out)
