"""Report folder of ``frictionrt diagnose --out``: diagnose.json (the JSON of the workflow),
model.toml (the updated model, loadable by --config), report.md, diagnosis.rrd (the overlays
for rerun: rt.discrepancy.diagnose.rrd), and overlay PNGs: per impulse
test |H| measured / nominal model (before) / updated model (after) over BAND_HZ, per FRF file the
same for every sensor over the file's whole band, in its quantity and unit, each with a panel of
the two models' residuals 20 log10(|H_measured| / |H_model|) [dB] below it (``overlay_figure``); per
actuator test the bolt force F_cell over time. Written into a temporary folder beside REPORT_DIR,
then renamed."""
from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from pathlib import Path

import numpy as np

from frictionrt.rt.common.config import dumps
from frictionrt.rt.discrepancy.diagnose.overlay import MODELS, overlay_figure
from frictionrt.rt.discrepancy.diagnose.rrd import write_diagnosis_rrd
from frictionrt.rt.discrepancy.diagnose.plausible import markdown
from frictionrt.rt.discrepancy.diagnose.localise import markdown as localise_markdown
from frictionrt.rt.discrepancy.diagnose.remainder import verdict
from frictionrt.rt.discrepancy.diagnose.campaign import (
    BAND_HZ,
    MIN_RSS_REDUCTION,
    NAME_THRESHOLD,
    NESTED_TOL,
    frf_overlays,
    public,
)


def _frf_file_plots(pl: dict, folder: Path, plt) -> list[str]:
    """Per FRF file one PNG, per sensor |H| measured, before, after over the whole band and the
    residuals [dB] of before and after."""
    names = []
    for name, F_N1, f, H, H0, H1 in pl["frf"]:
        panels = [(f"{pl['frf_quantity'][name]} |{s}| [{pl['frf_units'][name]}]", f, H[s],
                   {"before": H0[s], "after": H1[s]}) for s in H]
        fig = overlay_figure(f"{name}: F_N1 = {F_N1:.0f} N", panels, MODELS, loglog=True)
        names.append(f"frf_{name}.png")
        fig.savefig(folder / names[-1], dpi=110)
        plt.close(fig)
    return names

def _plots(res: dict, folder: Path) -> list[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    pl = res["_plots"]
    if "frf_units" in pl:
        return _frf_file_plots(pl, folder, plt)
    names = []
    for name, F_N1, f, H in frf_overlays(pl):
        sel = (f >= BAND_HZ[0]) & (f <= BAND_HZ[1])
        fig = overlay_figure(f"{name}: F_N1 = {F_N1:.0f} N", [
            ("accelerance |a_frf / F_exc| [(m/s^2)/N]", f[sel], H["measured"][sel], {k: H[k][sel] for k in MODELS})],
            MODELS)
        names.append(f"frf_{name}.png")
        fig.savefig(folder / names[-1], dpi=110)
        plt.close(fig)
    if not pl["act"]:
        return names
    (_, arun0), (_, arun1) = pl["before"], pl["after"]
    for t, r0, r1 in zip(pl["act"], arun0, arun1):
        fig, ax = plt.subplots(figsize=(8, 4))
        tt = np.arange(len(t.data["F_cell"])) * t.dt * 1e3
        ax.plot(tt, t.data["F_cell"], "k-", lw=0.8, label="measured")
        ax.plot(tt, r0["F_cell"], "C1--", lw=0.8, label="nominal model (before)")
        ax.plot(tt, r1["F_cell"], "C0-", lw=0.8, label="updated model (after)")
        ax.set_xlabel("t [ms]")
        ax.set_ylabel("bolt force F_cell [N]")
        ax.set_title(t.name)
        ax.legend()
        ax.grid(True, lw=0.3)
        fig.tight_layout()
        names.append(f"actuator_{t.name}.png")
        fig.savefig(folder / names[-1], dpi=110)
        plt.close(fig)
    return names

def dispersion_note(c: float) -> str:
    """One line of report.md on the fitted dispersion c (structure.warp)."""
    step = (f"the data's time step is {math.sqrt(1.0 - c):.2f} x the model's plant step" if c <= 1.0 else
            "beyond continuous time (c > 1): the warp takes a model-form error that rises with frequency")
    return (f"Dispersion c = {c:.3g}: the model's FRFs are read at f (1 - c (pi f h)^2 / 3), h the plant's step; "
            f"{step} (0: the virtual rig's own data, 1: continuous time, a laboratory's; docs/discrepancy.md, "
            "Method 3d). The written model.toml does not carry it.")

def report_md(res: dict, pngs: list[str]) -> str:
    named = res["named_effect"]
    gb, gc, ga = res["gap_before"], res["gap_calibrated"], res["gap_after"]
    lines = ["# Discrepancy report", "",
             f"**Named effect: {named or 'no missing effect found'}**"
             + (f" (runner-up: {res['runner_up']})" if named else ""),
             *(["", f"**Named model form: {', '.join(res['model_form']['named']) or 'none'}**"]
               if "model_form" in res else []),
             "", (f"Named only if its BIC is below calibration alone by more than {NAME_THRESHOLD:g}, it removes at "
                  f"least {100 * MIN_RSS_REDUCTION:g} % of its channels' residual sum of squares and its fitted "
                  f"strength is at least {100 * NESTED_TOL:g} % of its default away from nominal "
                  "(docs/discrepancy.md)."), "",
             ("| candidate | dBIC vs calibration | RSS reduction | BIC | feature gap after (rms of weighted "
              "residuals) | fitted |"), "| --- | --- | --- | --- | --- | --- |"]
    for r in res["ranking"]:
        lines.append(f"| {r['effect']} | {r['delta_bic']:.1f} | {100 * r['rss_reduction']:.1f} % | {r['score']:.1f} | "
                     f"{r['gap_after']:.3f} | {json.dumps(r['fitted'])} |")
    c = res["calibration_only"]
    lines += [f"| calibration only | 0 | 0 % | {c['score']:.1f} | {c['gap_after']:.3f} | {json.dumps(c['fitted'])} |"]
    lines += _model_form_section(res)
    if "dispersion" in res["fitted_parameters"]:
        lines += ["", dispersion_note(res["fitted_parameters"]["dispersion"])]
    lines += ["",
              "## Gap", "", "| test | metric | nominal (before) | calibrated only | updated (after) |",
              "| --- | --- | --- | --- | --- |"]
    for name, row in gb.items():
        if isinstance(row, dict):
            for k, v in row.items():
                lines.append(f"| {name} | {k} | {v} | {gc[name][k]} | {ga[name][k]} |")
    tests = "all FRF files" if res.get("input") == "frf_files" else "all impulse tests"
    lines += [f"| {tests} | mean FRF log-magnitude RMS [dB] | {gb['structure_frf_db']} | "
              f"{gc['structure_frf_db']} | {ga['structure_frf_db']} |"]
    if gb["actuator_nrmse"] is not None:
        lines += [f"| all actuator tests | mean F_cell NRMSE | {gb['actuator_nrmse']} | {gc['actuator_nrmse']} | "
                  f"{ga['actuator_nrmse']} |"]
    if "stepsine_ratio_db" in gb:
        lines.append(f"| all step-sine tests | F_amp / drive log-magnitude RMS [dB] | {gb['stepsine_ratio_db']} | "
                     f"{gc['stepsine_ratio_db']} | {ga['stepsine_ratio_db']} |")
    if res.get("input") == "frf_files":
        lines += [f"| all FRF files | mean over every sensor and the whole band [dB] | {gb['structure_frf_db_all']} | "
                  f"{gc['structure_frf_db_all']} | {ga['structure_frf_db_all']} |"]
    lines += _frf_file_sections(res)
    lines += ["", "## What calibration, the effect and the remainder explain", "", verdict(res), "",
              "```json", json.dumps(res["gap_budget"], indent=1), "```"]
    lines += ["", "## Localisation (nominal model vs measurement)", "",
              "```json", json.dumps(res["localisation"], indent=1), "```", "",
              f"Not tried (not implemented yet, or not seen by this input: no step-sine tests for "
              f"shaker_interaction, except on FRF files per drive volt; FRF files for slip and actuator effects): {_not_tried(res)}.", "",
              "Updated model: `model.toml` (use with `frictionrt --config model.toml ...`).", ""]
    lines += [f"![{p}]({p})" for p in pngs]
    return "\n".join(lines) + "\n"

def _model_form_section(res: dict) -> list[str]:
    """report.md's model-form candidates (FRF-file input): their rows of the ranking, the second round
    (forward selection with the first named candidate held) and the localisation table."""
    mf = res.get("model_form")
    if mf is None:
        return []
    out = ["", "## Model form", "",
           f"Candidates of the structure's form (diagnosis.model_form = {mf['mode']}): tried "
           f"{', '.join(mf['tried']) or 'none'}; named {', '.join(mf['named']) or 'none'}. Ranked with the effects "
           "above by the same rules.", ""]
    if mf["ranking"]:
        out += ["| model-form candidate | dBIC vs calibration | RSS reduction | fitted |", "| --- | --- | --- | --- |"]
        out += [f"| {r['effect']} | {r['delta_bic']:.1f} | {100 * r['rss_reduction']:.1f} % | {json.dumps(r['fitted'])} |"
                for r in mf["ranking"]]
    sr = res.get("second_round")
    if sr:
        out += ["", f"Second round: each candidate fitted together with {sr['first_named']} (alone at "
                    f"{sr['held_strength']:g}) or with the one the localisation points at, ranked against "
                    f"{sr['first_named']} alone; named: {sr['held'] + ' and ' + sr['named'] if sr['named'] else 'none'}.",
                "", "| candidate | with | kind | dBIC vs the first named | RSS reduction | fitted |",
                "| --- | --- | --- | --- | --- | --- |"]
        out += [f"| {r['effect']} | {r['with']} | {r['kind']} | {r['delta_bic']:.1f} | {100 * r['rss_reduction']:.1f} % | "
                f"{json.dumps(r['fitted'])} |" for r in sr["ranking"]]
    if res.get("where"):
        out += localise_markdown(res["where"])
    return out


def _not_tried(res: dict) -> str:
    """The effects not tried, each with its reason where the result gives one (FRF-file input)."""
    why = res.get("not_tried_reasons", {})
    return ", ".join(f"{e} ({why[e]})" if e in why else e for e in res["not_tried"])

def _frf_file_sections(res: dict) -> list[str]:
    """The FRF-file input's warnings, plausibility, excitation and sensors."""
    out = []
    if res.get("warnings"):
        out += ["", "## Warnings: parameters on a bound, level", "", "| parameter | value | bound | fix |", "| --- | --- | --- | --- |"]
        out += [f"| {w['parameter']} | {w['value']:g} | {'-' if w['bound'] is None else format(w['bound'], 'g')} | "
                f"{w['fix']} |" for w in res["warnings"]]
    if res.get("plausibility"):
        out += markdown(res["plausibility"])
    exc = res.get("excitation")
    if exc:
        out += ["", "## Excitation: drive voltage, no force", "",
                f"Fitted force scale: **{exc['force_scale_N_per_V']:g} N/V** (with the nominal model "
                f"{exc['force_scale_nominal_N_per_V']:g} N/V). {exc['note']}."]
    if res.get("sensors"):
        out += ["", "## Sensors", "", "| sensor | model point | quantity | unit |", "| --- | --- | --- | --- |"]
        out += [f"| {s} | {v['point']} | {v['quantity']} | {v['unit']} |" for s, v in res["sensors"].items()]
    return out

def write_report(res: dict, out: str | os.PathLike) -> Path:
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        (tmp / "diagnose.json").write_text(json.dumps(public(res), indent=1) + "\n")
        (tmp / "model.toml").write_text(dumps(res["_config"]))
        pngs = _plots(res, tmp)
        md = report_md(res, pngs)
        (tmp / "report.md").write_text(md)
        write_diagnosis_rrd(res, md, tmp / "diagnosis.rrd")
        tmp.chmod(0o755)
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out
