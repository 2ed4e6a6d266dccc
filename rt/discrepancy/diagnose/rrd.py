"""``diagnosis.rrd`` of ``frictionrt diagnose --out``: the report's overlays as a rerun recording,
for looking through the tests interactively (``rerun REPORT_DIR/diagnosis.rrd``).

Entities (rt.log.rrd_log.write_series_rrd):

    /frf/<test>/{measured, before, after}        20 log10 |a_frf / F_exc| [dB re 1 (m/s^2)/N]
                                                 per impulse test, timeline "freq_mHz"
    /frf/<test>/<sensor>/{measured, before, after}   the same per FRF file and sensor, in the file's
                                                 quantity and unit (dB re 1 of it), its whole band
    /frf_gap/<test>/{before, after}              20 log10 |H_meas / H_model| [dB]: where in
                                                 frequency the gap sits and how it shrank
    /actuator/<test>/{measured, before, after}   bolt force F_cell [N] per actuator test,
                                                 timeline "t" (duration)
    /report                                      report.md (rr.TextDocument, markdown)

``before`` is the nominal model, ``after`` the updated one (calibrated, with the named effect).
Blueprint: one tab per impulse test or FRF file (|H| above the gap, per sensor), one tab with
the actuator tests, and the report. The FRF bins are those of the report's overlays: BAND_HZ of
rt.discrepancy.diagnose.campaign for impulse tests, the whole band for FRF files.
"""
from __future__ import annotations

import os

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

from frictionrt.rt.discrepancy.diagnose.campaign import BAND_HZ, frf_overlays
from frictionrt.rt.log.rrd_log import freq_index, write_series_rrd

CURVES = ("measured", "before", "after")


def _part(name: str) -> str:
    return rr.escape_entity_path_part(name)


def diagnosis_series(res: dict) -> tuple[list, list]:
    """(series, views) of the recording from a diagnose result with its "_plots" data."""
    pl = res["_plots"]
    series, tabs = [], []
    if "frf_units" in pl:
        return _frf_file_series(pl)
    for name, _, f, H in frf_overlays(pl):
        e = _part(name)
        sel = (f >= BAND_HZ[0]) & (f <= BAND_HZ[1])
        index = freq_index(f[sel])
        db = {k: 20.0 * np.log10(np.abs(v[sel])) for k, v in H.items()}
        series += [(f"/frf/{e}/{k}", index, db[k]) for k in CURVES]
        series += [(f"/frf_gap/{e}/{k}", index, db["measured"] - db[k]) for k in ("before", "after")]
        tabs.append(rrb.Vertical(
            rrb.TimeSeriesView(origin=f"/frf/{e}", name=f"{name}: |H| [dB re 1 (m/s^2)/N] vs f [mHz]"),
            rrb.TimeSeriesView(origin=f"/frf_gap/{e}", name=f"{name}: measured - model [dB]"), name=name))
    if pl["act"]:
        (_, arun0), (_, arun1) = pl["before"], pl["after"]
        for t, r0, r1 in zip(pl["act"], arun0, arun1):
            index = rr.TimeColumn("t", duration=np.arange(len(t.data["F_cell"])) * t.dt)
            series += [(f"/actuator/{_part(t.name)}/{k}", index, y)
                       for k, y in zip(CURVES, (t.data["F_cell"], r0["F_cell"], r1["F_cell"]))]
        tabs.append(rrb.Grid(*[rrb.TimeSeriesView(origin=f"/actuator/{_part(t.name)}", name=f"{t.name}: F_cell [N]")
                               for t in pl["act"]], name="actuator"))
    tabs.append(rrb.TextDocumentView(origin="/report", name="report"))
    return series, [rrb.Tabs(*tabs)]


def _frf_file_series(pl: dict) -> tuple[list, list]:
    """(series, views) of FRF-file input: per file and sensor, the whole band (module docstring)."""
    series, tabs = [], []
    for name, _, f, H, H0, H1 in pl["frf"]:
        index = freq_index(f)
        views = []
        for s in H:
            e = f"{_part(name)}/{_part(s)}"
            db = {k: 20.0 * np.log10(np.abs(v[s])) for k, v in zip(CURVES, (H, H0, H1))}
            series += [(f"/frf/{e}/{k}", index, db[k]) for k in CURVES]
            series += [(f"/frf_gap/{e}/{k}", index, db["measured"] - db[k]) for k in ("before", "after")]
            views += [rrb.TimeSeriesView(origin=f"/frf/{e}", name=f"{name} {s}: {pl['frf_quantity'][name]} [dB re 1 "
                                         f"{pl['frf_units'][name]}] vs f [mHz]"),
                      rrb.TimeSeriesView(origin=f"/frf_gap/{e}", name=f"{name} {s}: measured - model [dB]")]
        tabs.append(rrb.Vertical(*views, name=name))
    tabs.append(rrb.TextDocumentView(origin="/report", name="report"))
    return series, [rrb.Tabs(*tabs)]


def write_diagnosis_rrd(res: dict, report_md: str, path: str | os.PathLike) -> None:
    """Write the recording of a diagnosis (module docstring) to ``path`` (``.part``, then renamed)."""
    series, views = diagnosis_series(res)
    named = res["named_effect"] or "none"
    write_series_rrd(path, "frictionrt-diagnose", series, views, metadata={"named_effect": named},
                     static={"/report": rr.TextDocument(report_md, media_type=rr.MediaType.MARKDOWN)})
