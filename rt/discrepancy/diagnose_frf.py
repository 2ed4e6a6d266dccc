"""The discrepancy workflow on measured FRFs (issue 7, docs/discrepancy.md "FRF-file input"): a
folder of FRF files (rt.log.frf_files: accelerances at several F_N1, CSV or UFF with sidecars) and a
nominal model of any structure (--config) instead of a time-series campaign.

The model of an FRF file is the linear one: the plant with the contact stuck at the test's F_N1,
its continuous accelerance at the sensors (plant.linear_frf.point_accelerances, the linearisation of
plant.linear_frf). It has no friction limit, so mu cannot act: calibration is E, k_t and the
modal damping (rt.discrepancy.diagnose_structure.CAL: bounds, priors), alone or with each implemented
structural candidate of rt.discrepancy.effects.

Data, per test and sensor s: ln|H_s| on the lines where it is above the noise; the noise of
ln|H| per line from the measurement itself: d_k = H_k - (H_{k-1} + H_{k+1}) / 2 (noise variance
x 1.5 where the FRF is smooth over two lines), its local level the running median of |d_k|^2 over
``NOISE_LINES`` lines / ln 2 (robust to the resonances the lines under-resolve), so that

    sigma_k^2 = median|d|^2 / (3 ln 2 |H_k|^2) + FLOOR^2,

lines with sigma_k > MAX_SIGMA (noise-filled antiresonances) left out (FLOOR, MAX_SIGMA as the
impulse workflow's, rt.discrepancy.diagnose_structure).

Stage 1: natural frequencies of modes 1-8 identified per test and sensor (plant.impulse.identify,
no window) against the stuck plant's undamped frequencies; E (and the candidate) fitted to them
(rt.discrepancy.diagnose_structure.fit_frequencies). Stage 2: weighted log-magnitude residuals
r = (ln|H_meas| - ln|H_model|) / sigma_k of all sensors and tests plus the calibration priors,
by rt.discrepancy.diagnose_structure's Gauss-Newton with Broyden updates, from the better of
stage 1 and the calibration with the candidate at nominal.
Ranking, naming conditions and result keys as rt.discrepancy.diagnose (rank, ranking_result); the gap is the
RMS of 20 log10|H_meas / H_model| of a_frf_meas over rt.discrepancy.diagnose.BAND_HZ per test [dB].
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.ndimage import median_filter
from threadpoolctl import threadpool_limits

from plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from rt.common.config import Config, with_sets
from rt.discrepancy.diagnose import BAND_HZ, bic, modes_table, rank, ranking_result
from rt.discrepancy.diagnose_structure import (
    CAL,
    EFFECT_STEP,
    FLOOR,
    MAX_SIGMA,
    MODES,
    SENSORS,
    bounds,
    prior,
    fit_frequencies,
    gauss_newton_broyden,
    identify_modes,
    jacobian_column,
    struct_cfg,
)
from rt.discrepancy.effects import EFFECTS, Effect, implemented
from rt.log.frf_files import FRFTest, frf_files, load_frf_folder
from plant.linear_frf import point_accelerances
from rt.discrepancy.chain import quiet
from rt.discrepancy.rig_frf import sensor_points

NOISE_LINES = 31                 # running-median window of the noise estimate [lines]
POSITION_TOL_M = 1e-3            # sidecar positions must match the model's points within this [m]
CAL_NAMES = ("E", "k_t", "modal_damping")   # mu cannot act on the stuck linear model


class FRFData(NamedTuple):
    name: str
    F_N1: float
    freq: np.ndarray             # all lines [Hz]
    H: dict                      # sensor -> measured H on all lines
    sel: dict                    # sensor -> bool mask of the fitted lines
    ln_h: dict                   # sensor -> ln|H_meas| on sel
    sigma: dict                  # sensor -> sigma_k on sel
    f_modes: dict                # sensor -> identified f [Hz] of MODES (NaN: not found or no sensor)
    stuck: bool = True           # fit_frequencies uses stuck tests: all are (linear measurements)


def is_frf_folder(folder: str | Path) -> bool:
    """A folder of FRF files: FRF data files (rt.log.frf_files) and no *.mcap measurement."""
    folder = Path(folder)
    return folder.is_dir() and not any(folder.glob("*.mcap")) and bool(frf_files(folder))


def undamped_frequencies(model, F_N1: float) -> np.ndarray:
    """The stuck plant's first len(MODES) natural frequencies at F_N1 [N] (continuous) [Hz]."""
    return stuck_frequencies_hz(model, preloaded_pairs(model, F_N1))[:len(MODES)]


def check_positions(test: FRFTest, cfg: Config) -> None:
    """The sidecar's excitation and sensor positions are the model's points; ValueError otherwise."""
    pts = {p.name: p.x_m for p in cfg.plant.points}
    want = {"excitation": (test.meta["excitation_x_m"], pts[cfg.plant.excitation_point],
                           cfg.plant.excitation_point)}
    want |= {s: (test.meta["sensor_positions_m"][s], pts[p], p) for s, p in sensor_points(cfg).items() if s in test.H}
    for what, (x_file, x_model, point) in want.items():
        if abs(x_file - x_model) > POSITION_TOL_M:
            raise ValueError(f"{test.name}: {what} at x = {x_file:g} m, but the model's point {point!r} is at "
                             f"{x_model:g} m; give the structure of the test with --config, or correct the sidecar")


def noise_sigma(H: np.ndarray) -> np.ndarray:
    """sigma_k of ln|H| per line (module docstring)."""
    d = np.empty(len(H))
    d[1:-1] = np.abs(H[1:-1] - 0.5 * (H[:-2] + H[2:])) ** 2
    d[0], d[-1] = d[1], d[-2]
    level = median_filter(d, size=NOISE_LINES, mode="nearest") / math.log(2.0)
    return np.sqrt(level / (3.0 * np.abs(H) ** 2) + FLOOR ** 2)


def prepare(tests: list[FRFTest], nominal: Config) -> list[FRFData]:
    """The fitted lines, ln|H|, sigma and identified mode frequencies of every test."""
    for t in tests:
        check_positions(t, nominal)
    m0 = build_plant(quiet(nominal))
    out = []
    for t in tests:
        f_nom = undamped_frequencies(m0, t.F_N1)
        f_nom = f_nom[f_nom * 1.08 < t.freq_hz[-1]]
        sel, ln_h, sig, fm = {}, {}, {}, {}
        for s in SENSORS:
            if s not in t.H:
                fm[s] = np.full(len(MODES), np.nan)
                continue
            sk = noise_sigma(t.H[s])
            sel[s] = sk < MAX_SIGMA
            ln_h[s] = np.log(np.abs(t.H[s][sel[s]]))
            sig[s] = sk[sel[s]]
            fm[s] = identify_modes(t.freq_hz, t.H[s], math.inf, f_nom)
        out.append(FRFData(t.name, t.F_N1, t.freq_hz, t.H, sel, ln_h, sig, fm))
    return out


def model_H(cfg: Config, data: list[FRFData]) -> list[dict]:
    """The model's accelerances {sensor: H} on every test's lines at its F_N1."""
    model = build_plant(quiet(cfg))
    pts = sensor_points(cfg)
    return [point_accelerances(model, {s: pts[s] for s in d.sel}, d.F_N1, d.freq) for d in data]


def residuals(cfg: Config, data: list[FRFData]) -> tuple[dict, list[dict]]:
    """({"FRF <sensor>": weighted log-magnitude residuals over all tests}, model H per test)."""
    Hm = model_H(cfg, data)
    r = {s: [] for s in SENSORS}
    for d, h in zip(data, Hm):
        for s in d.sel:
            r[s].append((d.ln_h[s] - np.log(np.maximum(np.abs(h[s][d.sel[s]]), 1e-300))) / d.sigma[s])
    return {f"FRF {s}": np.concatenate(v) for s, v in r.items() if v}, Hm


class Fit(NamedTuple):
    theta: dict
    channels: dict       # "FRF <sensor>" -> weighted residuals
    H: list              # model {sensor: H} per test
    cfg: Config
    J: dict              # parameter -> Jacobian column at theta (reused by the candidates)


def fit(nominal: Config, data: list[FRFData], effect: Effect | None, calibrated: Fit | None = None) -> Fit:
    """Stage 1 then stage 2 (module docstring) of the calibration alone (effect None) or with the
    effect; with ``calibrated`` stage 2 starts from the better of stage 1 and the calibration with
    the effect at its nominal strength, there with the calibration's Jacobian columns (so a
    candidate never fits worse than calibration alone). Stage 2 is rt.discrepancy.diagnose_structure's
    Gauss-Newton with Broyden updates (a finite-difference Jacobian only at the start and when a
    step fails)."""
    names = list(CAL_NAMES) + ([effect.name] if effect else [])
    lo, hi = bounds(names, effect)
    steps = np.array([CAL[k][3] if k in CAL else EFFECT_STEP * effect.parameter.default for k in names])

    def evaluate(x):
        ch, H = residuals(struct_cfg(nominal, dict(zip(names, x)), effect), data)
        return (ch, H), np.concatenate([*ch.values(), prior(names, x)])

    stage1 = fit_frequencies(nominal, data, effect, frequencies=undamped_frequencies)
    x = np.clip([stage1.get(k, 1.0) for k in names], lo, hi)
    run, r = evaluate(x)
    J = None
    if calibrated is not None and effect is not None:
        x_cal = np.array([calibrated.theta.get(k, effect.nominal) for k in names])
        r_cal = np.concatenate([*calibrated.channels.values(), prior(names, x_cal)])
        if r_cal @ r_cal < r @ r:
            x, run, r = x_cal, (calibrated.channels, calibrated.H), r_cal
            J = np.column_stack([calibrated.J[k] for k in names[:-1]]
                                + [jacobian_column(evaluate, x, r, len(names) - 1, steps, hi)])
    x, (ch, H), r, J = gauss_newton_broyden(evaluate, x, run, r, J, lo, hi, steps)
    theta = dict(zip(names, map(float, x)))
    return Fit(theta, ch, H, struct_cfg(nominal, theta, effect), dict(zip(names, J.T)))


def gap_db(data: list[FRFData], Hm: list[dict]) -> dict:
    """RMS of 20 log10|H_meas / H_model| of a_frf_meas over BAND_HZ per test [dB] and their mean
    ("structure_frf_db"); "actuator_nrmse" None (no actuator test)."""
    out = {}
    for d, h in zip(data, Hm):
        s = "a_frf_meas" if "a_frf_meas" in d.sel else next(iter(d.sel))
        band = (d.freq >= BAND_HZ[0]) & (d.freq <= BAND_HZ[1])
        out[d.name] = {"frf_db": round(float(np.sqrt(np.mean(
            (20 * np.log10(np.abs(d.H[s][band]) / np.abs(h[s][band]))) ** 2))), 4)}
    out["structure_frf_db"] = round(float(np.mean([out[d.name]["frf_db"] for d in data])), 4)
    out["actuator_nrmse"] = None
    return out


def diagnose_frf(folder: str | Path, nominal: Config | None = None, progress=None) -> dict:
    """The workflow (module docstring) on a folder of FRF files; the result dict as rt.discrepancy.diagnose's,
    with the fitted configuration under "_config" and the plotting data under "_plots"."""
    with threadpool_limits(1):
        return _diagnose_frf(folder, nominal, progress or (lambda msg: None))


def _candidates(nominal: Config) -> tuple[list[Effect], dict[str, str]]:
    """The implemented effects linear FRFs can show (``Effect.visible_in_frf_files``: structural, and
    changing the stuck structure) that the structure has a place for (a clamp, an adaptive screw,
    the accelerometer points): those that apply to ``nominal`` at their default strength; and
    {name: why not} for every other effect of the library."""
    out, why = [], {}
    for e in EFFECTS.values():
        if not e.implemented:
            why[e.name] = "not implemented yet"
            continue
        if not e.visible_in_frf_files():
            why[e.name] = "linear stuck-contact FRFs cannot show it (it acts through slip or the actuator)"
            continue
        try:
            e.apply(nominal, e.parameter.default)
        except (ValueError, KeyError, StopIteration) as exc:
            why[e.name] = f"does not apply to this structure: {exc}"
            continue
        out.append(e)
    return out, why


def _diagnose_frf(folder, nominal: Config | None, say) -> dict:
    nominal = nominal if nominal is not None else with_sets(Config(), [])
    tests = load_frf_folder(folder)                          # bad input raises before any progress line
    try:
        data = prepare(tests, nominal)
    except ValueError as exc:
        raise ValueError(f"{folder}: {exc}") from None
    if not any(d.sel for d in data):
        raise ValueError(f"{folder}: no FRF line above the noise in any test")
    ch0, H0 = residuals(nominal, data)
    say("fit calibration only")
    fits = {None: fit(nominal, data, None)}
    candidates, why_not = _candidates(nominal)
    for eff in candidates:
        say(f"fit {eff.name}")
        fits[eff] = fit(nominal, data, eff, calibrated=fits[None])
    results = [{"effect": e.name if e else None, "theta": f.theta, "channels": f.channels,
                "score": bic(f.channels, len(f.theta)), "fit": f, "cfg": f.cfg} for e, f in fits.items()]
    base, ranked, winner = rank(results)
    final = winner or base
    m0 = build_plant(quiet(nominal))
    localise = {d.name: {"F_N1_N": round(d.F_N1, 1), "frf_db_nominal": gap_db([d], [h])[d.name]["frf_db"],
                         "modes": modes_table(undamped_frequencies(m0, d.F_N1), d.f_modes)}
                for d, h in zip(data, H0)}
    gap = {"gap_before": gap_db(data, H0), "gap_calibrated": gap_db(data, base["fit"].H),
           "gap_after": gap_db(data, final["fit"].H)}
    m1 = build_plant(quiet(final["cfg"]))
    modes_after = {d.name: modes_table(undamped_frequencies(m1, d.F_N1), d.f_modes) for d in data}
    out = ranking_result(base, ranked, winner, gap, localise, ch0, modes_after)
    out["not_tried"] += [e.name for e in implemented() if e not in candidates]   # not visible in linear FRFs, or no place
    return out | {"input": "frf_files", "not_tried_reasons": why_not,
                  "_plots": {"frf": [(d.name, d.F_N1, d.freq, d.H, h0, h1)
                                     for d, h0, h1 in zip(data, H0, final["fit"].H)], "act": []}}
