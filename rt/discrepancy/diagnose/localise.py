"""Localisation of FRF-file input (docs/discrepancy.md "Where the model is wrong"): per measured mode
its frequency, damping and residuals against the calibrated model, and the parameters (calibration
scales, effects, model-form candidates) whose frequency sensitivities match the pattern of the
measured modes' shifts, computed after the calibration alone and before any candidate is fitted or
named.

Per test and model mode j paired with a measured one (rt.discrepancy.diagnose.frf_modes): f_meas,
zeta_meas (plant.impulse.identify at the peak), the nominal and the calibrated model's undamped
frequencies, the peak residual 20 log10 |H_meas / H_cal| [dB] at the measured mode's line (the
sensor where it is largest in magnitude), and with two or more sensors the shape residual 1 - MAC
of the measured shape (H_s at the line) against the calibrated model's mode shape at the sensors
(with one sensor a shape has no residual: None).

Pattern: d_j = ln(f_meas / f_nominal) over every paired mode of every test. Signature of a parameter
p: S_pj = ln(f_j(p) / f_j(nominal)) of the nominal's stuck frequencies (plant.model.
stuck_frequencies_hz) with p moved by ``STEP`` (the calibration scales E, k_t) or at its default
strength (a candidate): the secant of its shift pattern. Two numbers per parameter, each a
least-squares fit of d by the signature:

    alone:        share = 1 - |d - a S_p|^2 / |d|^2,                         a >= 0 for a candidate,
    beyond E:     share = 1 - |d - a S_p - b S_E|^2 / |d - b_E S_E|^2     (b free, b_E the fit by E alone),

the second the share of what E (a uniform frequency scale) leaves that p explains: the pattern
(mode 2 -25 % and mode 1 -10 % point at the joint, not the clamp, whose shifts are nearly uniform).
``a`` is the strength multiple of the signature's step that fits (alone and beside E). The parameters are listed by the share
beyond E (the share alone breaks ties: E itself explains nothing beyond E).
"""
from __future__ import annotations

import math

import numpy as np

from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from frictionrt.rt.common.config import Config
from frictionrt.rt.discrepancy.chain import quiet, scaled
from frictionrt.rt.discrepancy.diagnose.frf_modes import mac, model_modes
from frictionrt.rt.discrepancy.effects import Effect

STEP = {"E": 0.9, "k_t": 0.1}    # the calibration scales' signature steps (x nominal): E -10 %, k_t a decade down
MIN_MODES = 2                    # fewer paired modes than this: no pattern to match


def _frequencies(cfg: Config, levels: list[float], n: int) -> np.ndarray:
    """(tests, n) undamped stuck frequencies [Hz] of ``cfg`` at each F_N1 [N] of ``levels``."""
    model = build_plant(quiet(cfg))
    return np.array([stuck_frequencies_hz(model, preloaded_pairs(model, F))[:n] for F in levels])


def signatures(nominal: Config, levels: list[float], n: int, candidates: list[Effect]) -> dict[str, dict]:
    """{parameter: {"kind", "step", "S": (tests, n) ln frequency ratio}} of the calibration scales of
    ``STEP`` and of each candidate at its default strength (module docstring)."""
    f0 = _frequencies(nominal, levels, n)
    out = {}
    for k, s in STEP.items():
        if k == "k_t" and not nominal.plant.interface.enabled:
            continue
        out[k] = {"kind": "calibration", "step": s, "S": np.log(_frequencies(scaled(nominal, {k: s}), levels, n) / f0)}
    for e in candidates:
        f = _frequencies(e.apply(nominal, e.parameter.default), levels, n)
        out[e.name] = {"kind": "model form" if e.form else "effect", "step": e.parameter.default,
                       "S": np.log(f / f0)}
    return out


def _fit(d: np.ndarray, cols: list[np.ndarray], nonneg_first: bool) -> tuple[np.ndarray, float]:
    """(coefficients, residual sum of squares) of d by the columns, the first >= 0 if ``nonneg_first``."""
    A = np.column_stack(cols)
    c = np.linalg.lstsq(A, d, rcond=None)[0]
    if nonneg_first and c[0] < 0.0:
        c = np.r_[0.0, np.linalg.lstsq(A[:, 1:], d, rcond=None)[0]] if A.shape[1] > 1 else np.zeros(1)
    r = d - A @ c
    return c, float(r @ r)


def match(d: np.ndarray, sig: dict[str, dict]) -> list[dict]:
    """The parameters' rows (module docstring): {"parameter", "kind", "share_alone", "share_beyond_E",
    "multiple"} for the pattern d over the finite entries (NaN: unpaired), best first."""
    ok = np.isfinite(d)
    d = d[ok]
    dd = float(d @ d)
    rows = []
    if len(d) < MIN_MODES or dd == 0.0:
        return rows
    S_E = sig["E"]["S"].ravel()[ok] if "E" in sig else None
    rss_E = _fit(d, [S_E], False)[1] if S_E is not None else dd
    for k, v in sig.items():
        S = v["S"].ravel()[ok]
        if not np.any(S):
            continue
        cand = v["kind"] != "calibration"
        a, rss = _fit(d, [S], cand)
        if k == "E" or S_E is None:
            beyond, b = 0.0, a
        else:
            b, rss2 = _fit(d, [S, S_E], cand)
            beyond = 1.0 - rss2 / rss_E if rss_E > 0 else 0.0
        rows.append({"parameter": k, "kind": v["kind"], "share_alone": round(1.0 - rss / dd, 4),
                     "share_beyond_E": round(beyond, 4), "multiple": float(f"{a[0]:.4g}"),
                     "multiple_beyond_E": float(f"{b[0]:.4g}"), "step": v["step"]})
    return sorted(rows, key=lambda r: (-r["share_beyond_E"], -r["share_alone"]))


def _r(x, nd=4):
    x = float(x)
    return round(x, nd) if math.isfinite(x) else None


def mode_rows(data, H_cal: list[dict], f_nominal: np.ndarray, cal: Config) -> dict:
    """{test: [row per paired mode]} (module docstring); ``data`` FRFData, ``H_cal`` the calibrated
    model's {sensor: H} per test, ``f_nominal`` (tests, n) the nominal's frequencies, ``cal`` the calibrated
    configuration (its mode shapes; it holds the sensors' points)."""
    model = build_plant(quiet(cal))
    out = {}
    for d, h, f0 in zip(data, H_cal, f_nominal):
        sensors = list(d.H)
        mm = model_modes(model, d.F_N1, [d.points[s] for s in sensors], len(f0))
        rows = []
        for j, fm in enumerate(d.f_modes["measured"][:len(f0)]):
            if not np.isfinite(fm):
                continue
            line = int(np.argmin(np.abs(d.freq - fm)))
            res = [20 * math.log10(abs(d.H[s][line]) / abs(h[s][line])) for s in sensors]
            peak = max(res, key=abs)
            shape = None
            if len(sensors) >= 2 and j < len(mm.f_hz):
                shape = _r(1.0 - mac(mm.shapes[j], np.array([d.H[s][line] for s in sensors])))
            zeta = d.zeta_modes[j] if d.zeta_modes is not None else math.nan
            rows.append({"mode": j + 1, "f_meas_hz": _r(fm, 3), "zeta_meas": _r(zeta, 5),
                         "f_nominal_hz": _r(f0[j], 3), "shift_nominal": _r(fm / f0[j] - 1.0),
                         "f_calibrated_hz": _r(mm.f_hz[j], 3) if j < len(mm.f_hz) else None,
                         "shift_calibrated": _r(fm / mm.f_hz[j] - 1.0) if j < len(mm.f_hz) else None,
                         "peak_residual_db": _r(peak, 3), "shape_residual": shape})
        out[d.name] = rows
    return out


def localise(data, nominal: Config, cal: Config, H_cal: list[dict], candidates: list[Effect], n: int) -> dict:
    """The localisation table (module docstring): {"modes": {test: rows}, "parameters": rows best first,
    "points_at": the best candidate (effect or model form) beyond E, or None}."""
    levels = [d.F_N1 for d in data]
    sig = signatures(nominal, levels, n, candidates)
    f0 = _frequencies(nominal, levels, n)
    meas = np.array([np.r_[d.f_modes["measured"][:n], np.full(max(0, n - len(d.f_modes["measured"])), np.nan)]
                     for d in data])
    pattern = np.log(meas / f0).ravel()
    params = match(pattern, sig)
    cand = [r for r in params if r["kind"] != "calibration" and r["multiple_beyond_E"] > 0.0]
    return {"modes": mode_rows(data, H_cal, f0, cal), "parameters": params,
            "points_at": cand[0]["parameter"] if cand and cand[0]["share_beyond_E"] > 0.0 else None}


def markdown(loc: dict) -> list[str]:
    """report.md's localisation section."""
    out = ["", "## Where the model is wrong (localisation, before any candidate is named)", "",
           "Per measured mode against the nominal and the calibrated model (peak residual: 20 log10 |H_meas / "
           "H_calibrated| at the mode's line, the sensor where it is largest; shape residual 1 - MAC, with two "
           "or more sensors).", "",
           "| test | mode | f measured [Hz] | zeta measured | f nominal [Hz] | shift vs nominal | f calibrated [Hz] | "
           "shift vs calibrated | peak residual [dB] | shape residual |",
           "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for test, rows in loc["modes"].items():
        for r in rows:
            out.append(f"| {test} | {r['mode']} | {r['f_meas_hz']} | {r['zeta_meas']} | {r['f_nominal_hz']} | "
                       f"{r['shift_nominal']} | {r['f_calibrated_hz']} | {r['shift_calibrated']} | "
                       f"{r['peak_residual_db']} | {'-' if r['shape_residual'] is None else r['shape_residual']} |")
    out += ["", "Parameters whose frequency signature matches the measured shifts (share of the shifts' sum of "
                "squares explained alone, and of what a uniform scale E leaves; multiple: of the signature's step):", "",
            "| parameter | kind | share alone | share beyond E | multiple of step (alone, beyond E) | step |",
            "| --- | --- | --- | --- | --- | --- |"]
    out += [f"| {r['parameter']} | {r['kind']} | {r['share_alone']:.3f} | {r['share_beyond_E']:.3f} | "
            f"{r['multiple']:g}, {r['multiple_beyond_E']:g} | {r['step']:g} |" for r in loc["parameters"]]
    out += ["", f"The pattern points at: **{loc['points_at'] or 'nothing beyond a uniform scale'}**."]
    return out


def form_lines(result: dict) -> list[str]:
    """The CLI summary's lines of a diagnosis of FRF files: the model form named and tried, the second round,
    what the localisation points at (none for other input)."""
    if "model_form" not in result:
        return []
    mf = result["model_form"]
    out = [f"named model form: {', '.join(mf['named']) or 'none'} (tried: {', '.join(mf['tried']) or 'none'})"]
    if result.get("second_round"):
        sr = result["second_round"]
        out.append(f"second round (pairs with {sr['first_named']}, or with what the localisation points at): named "
                   f"{sr['held'] + ' and ' + sr['named'] if sr['named'] else 'none'}")
    return out + [f"localisation: the measured modes' shifts point at {result['where']['points_at'] or 'nothing'}"]
