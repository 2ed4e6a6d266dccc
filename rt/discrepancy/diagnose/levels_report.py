"""The amplitude-dependence diagnosis' report (rt.discrepancy.diagnose.levels): the text the CLI prints,
diagnose.json, model.toml, report.md and levels.png (per level |H| and the residuals [dB]; an interrupted diagnosis': rt.discrepancy.diagnose.watch).
Moved out of levels.py unchanged."""
from __future__ import annotations

from pathlib import Path


from frictionrt.rt.discrepancy.diagnose.overlay import overlay_figure
from frictionrt.rt.discrepancy.diagnose.plausible import markdown, summary_lines
from frictionrt.rt.discrepancy.diagnose.watch import fitted_text, write_result


def summary(res: dict) -> str:
    """The text the CLI prints."""
    lines = [f"calibrated on {', '.join(f'{a:g}' for a in res['calibrate_on_n'])} {res['level_unit']} (harmonic balance: "
             f"{res['harmonic_method']}); softening mode "
             f"{res['softening_mode']} ({res['softening_band_hz'][0]:g}-{res['softening_band_hz'][1]:g} Hz)",
             form_line(res),
             f"named effect: {res['named_effect'] or 'no missing effect found'}",
             f"fitted (harmonic balance): {fitted_text(res['nonlinear']['fitted'])}",
             calibration_line(res),
             *([f"note: {res['contact_note']}"] if res["contact_note"] else []),
             *[f"warning ({w['model']}): {w['parameter']} = {w['value']:g} at its bound {w['bound']:g}: {w['fix']}"
               for w in res["warnings"]],
             *summary_lines(res["plausibility"]),
             f"level [{res['level_unit']}]  calibrated  gap linear / harmonic balance [dB] (softening band; all lines)  "
             "ratio  better"]
    for p in res["prediction"]:
        lines.append(f"  {p['level_n']:>7g}  {'yes' if p['calibrated_on'] else 'no':>10}  "
                     f"{p['gap_linear_db']:.3f} / {p['gap_nonlinear_db']:.3f}  ({p['gap_linear_all_db']:.3f} / "
                     f"{p['gap_nonlinear_all_db']:.3f})  {p['ratio']}  {p['better']}"
                     + (f"  (aft {p['gap_aft_db']:.3f} / {p['gap_aft_all_db']:.3f})" if "gap_aft_db" in p else ""))
    return "\n".join(lines)


def form_line(res: dict) -> str:
    """The model form at the calibration levels (rt.discrepancy.diagnose.levels_form): named and held, or why not."""
    f = res.get("model_form")
    if not f:
        return "model form: not tried"
    held = ", ".join(f"{n} = {v:g}" for n, v in f.get("strengths", {}).items())
    if f.get("mode") == "given":
        return f"model form given and held in both level models: {held}"
    if f.get("reason"):
        return f"model form: not tried ({f['reason']})"
    on = f" on {f['on']}" if f.get("on") else ""
    if not f.get("named"):
        return f"model form{on}: nothing named of {', '.join(f.get('tried', []))}"
    return f"model form named{on} and held in both level models: {held}"


def calibration_line(res: dict) -> str:
    """The two models at the calibration levels by their common objective, and a refused harmonic-balance fit."""
    c = res["calibration_gap"]
    text = (f"at the calibration levels (rms of the weighted log-magnitude residual over the modes' bands, 1 = noise): "
            f"linear {c['linear']:g}, harmonic balance {c['nonlinear']:g}")
    if c["refused"]:
        text += ("; the harmonic balance's fit ended worse than its stuck limit (the linear model): refused, "
                 "the stuck limit kept")
    return text


def write_levels_report(res: dict, out: str | Path) -> Path:
    """The report folder (a new folder, written beside and renamed: never half a report):
    diagnose.json, model.toml (the calibrated harmonic-balance model), report.md and levels.png
    (per level the measured |H| of the first sensor, the linear and the harmonic-balance prediction, and
    below it their residuals measured - model [dB])."""
    import json

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from frictionrt.rt.discrepancy.rig.campaign import new_folder
    with new_folder(out) as tmp:
        write_result(tmp, res)
        plots = res["_plots"]
        s = next(iter(plots[0][3]))      # the first sensor
        panels = [(f"{name}: {a:g} {res['level_unit']}\n({'calibrated on' if a in res['calibrate_on_n'] else 'predicted'})"
                   f" |{s}|", f, H[s], {"linear": h0[s], "hb": h1[s]}) for name, a, f, H, h0, h1 in plots]
        fig = overlay_figure(f"measured {s} and the models, each level", panels,
                             {"linear": ("linear (stuck)", "C1-"), "hb": ("harmonic balance", "C0-")})
        for ax in fig.axes:
            ax.axvspan(*res["softening_band_hz"], color="0.9", zorder=0)
            ax.yaxis.label.set_fontsize(7)
        fig.savefig(tmp / "levels.png", dpi=110)
        plt.close(fig)
        rows = [f"| {p['level_n']:g} | {'yes' if p['calibrated_on'] else 'no'} | {p['gap_linear_db']} | "
                f"{p['gap_nonlinear_db']} | {p['ratio']} | {p['better']} | {p['gap_linear_all_db']} | "
                f"{p['gap_nonlinear_all_db']} | {p.get('gap_aft_db', '')} |" for p in res["prediction"]]
        (tmp / "report.md").write_text("\n".join([
            "# Amplitude dependence: calibrated at some levels, predicted at the others", "",
            f"Calibrated on {', '.join(f'{a:g}' for a in res['calibrate_on_n'])} {res['level_unit']}. Softening mode "
            f"{res['softening_mode']}, band {res['softening_band_hz'][0]:g}-{res['softening_band_hz'][1]:g} Hz "
            "(docs/discrepancy.md, \"Amplitude dependence\").", "",
            form_line(res)[0].upper() + form_line(res)[1:] + ".", "",
            f"**Named effect: {res['named_effect'] or 'no missing effect found'}**", "",
            f"Harmonic balance: method {res['harmonic_method']}." + (f" Note: {res['contact_note']}." if res["contact_note"]
                                                                     else ""), "",
            f"Harmonic-balance calibration: `{json.dumps(res['nonlinear']['fitted'])}`; linear: "
            f"`{json.dumps(res['linear']['fitted'])}`.", "",
            calibration_line(res)[0].upper() + calibration_line(res)[1:] + ".", "",
            f"| level [{res['level_unit']}] | calibrated on | gap linear [dB] | gap harmonic balance [dB] | ratio | better "
            "| linear, all lines | harmonic balance, all lines | aft from this calibration [dB] |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
            *rows, "",
            *(["", "## Warnings: parameters on a bound", "", "| model | parameter | value | bound | fix |",
               "| --- | --- | --- | --- | --- |"]
              + [f"| {w['model']} | {w['parameter']} | {w['value']:g} | {w['bound']:g} | {w['fix']} |"
                 for w in res["warnings"]] if res["warnings"] else []), "",
            *markdown(res["plausibility"]), "",
            "![levels.png](levels.png)", ""]))
    return Path(out)
