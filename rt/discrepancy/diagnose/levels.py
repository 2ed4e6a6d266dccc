"""FRFs at several excitation levels: calibrate at some, predict the others (``diagnose --calibrate-on``;
docs/discrepancy.md "Amplitude dependence").

Input: a folder of FRF files (rt.log.frf_files) of one structure at one bolt force and several force
amplitudes (sidecar ``amplitude_n`` [N]; e.g. ``rig --frf-files --levels``). The question a lab asks:
calibrated where the joint just starts to slip (the lowest levels), does the model predict the
higher ones? Two models, both calibrated on the tests at the levels ``calibrate_on`` only:

* linear: rt.discrepancy.diagnose.frf's stuck model (plant.linear_frf), the same FRF at every level,
  calibrated as there (E, k_t, modal damping);
* nonlinear: the harmonic balance of the joints at each test's force amplitude (plant.harmonic_frf,
  one start per line), calibrated in E, k_t, mu and the modal damping, alone and with each slip
  candidate of the library that it can represent (micro_slip: the Iwan spread; Stribeck friction is
  velocity-dependent, which neither method holds: not tried), and clamp compliance (the structural candidate
  that takes the place of a calibration pressed against its plausible ranges). ``method`` "df" (default): each
  closed pair's Jenkins / Iwan describing function k_eq(|g_t|) with the slip force mu f_n at its static normal
  force, the normal contact linear; ~0.1 s per model evaluation (its build) plus 0.06 ms a line and level
  (docs/plant.md 10). "aft": the plant's own pair law
  marched over the period (contact opening and closing, slip limit mu f_n(t)), 3 harmonics, on the lines where
  df's normal ratio of a closed pair reaches ``AFT_RATIO`` (df's solution on the others, where the two agree:
  ``aft_where_open``); 0.5-0.9 s per level of 45 lines on the aluminium lap joint, whose overlap ends gape
  (there df's 10 N prediction is 2.9x closer than the linear model's, aft's 49x: docs/discrepancy.md). With "df" the
  prediction reports where a closed pair's normal gap swings more than its static gap (``contact_note``).

Residuals: rt.discrepancy.diagnose.frf's, (ln|H_meas| - ln|H_model|) / sigma_k on the lines above the
noise, every sensor; both models on the modes' bands only (``mode_bands``: +-``HALF_WIDTH`` around each
measured mode, where the joint shows; each band weighted to the same total, so that a lab's dense lines at
a high mode do not outvote a low mode's), and compared at the calibration levels by that objective
(``calibration_gap``: a harmonic-balance fit worse than its stuck limit, the linear model, is refused). Fit:
scipy.optimize.least_squares (trust-region reflective) in the logarithms of the scales, within
``fit_bounds``, from the linear calibration's E, k_t and damping and mu x 1 (the
candidate from its default strength, moved as strength / its range: scipy's finite-difference step is
relative to max(1, |x|), 1e-3 of a clamp compliance's range rather than twice its range), penalised outside
the parameters' plausible ranges (rt.discrepancy.diagnose.plausible; the report's "plausibility" names those
that want to leave them). A line where the harmonic balance does not converge is given the constant weighted residual
rt.discrepancy.diagnose.frf.NO_SOLUTION, so a parameter set that leaves the balance without a solution is
never preferred.

Ranking of the candidates on the calibration levels: BIC as rt.discrepancy.diagnose.campaign, named under its
three conditions (rank). Prediction: at every level not calibrated on, the gap [dB] = RMS of
20 log10|H_meas / H_model| over the band of the softening mode (``softening_band``: +-``HALF_WIDTH``
around the stuck model's mode whose measured peak moves most from the lowest to the highest level)
and over all lines, for both models, and their ratio.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from threadpoolctl import threadpool_limits

from frictionrt.plant.harmonic_frf import METHODS, harmonic_system
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.chain import quiet, scale_bounds, scaled
from frictionrt.rt.discrepancy.diagnose.campaign import bic, rank
from frictionrt.rt.discrepancy.diagnose.frf import (CAL_NAMES as FRF_CAL_NAMES, FORCE_SCALE, FORCE_SCALE_N_PER_V,
                                                    FRFData, bound_warnings, fit, model_H, prepare,
                                                    undamped_frequencies, weighted_residuals, with_sensor_points)
from frictionrt.rt.discrepancy.diagnose.levels_form import corrected, fit_form, form_candidates
from frictionrt.rt.discrepancy.diagnose.random_level import RandomLevel, is_random, level_accelerances, random_levels
from frictionrt.rt.discrepancy.diagnose.structure import CAL_FAR
from frictionrt.rt.discrepancy.effects import Effect, get
from frictionrt.rt.discrepancy.diagnose.plausible import CLAMP, outside, penalty, ranges, verdict
from frictionrt.rt.discrepancy.diagnose.watch import done_fit, keeping, rounded, watch
from frictionrt.rt.log.frf_files import FRFTest, from_accelerance, load_frf_folder

CAL_NAMES = ("E", "k_t", "mu", "modal_damping")
BOUNDS = {k: CAL_FAR[k][:2] for k in ("E", "k_t", "modal_damping")} | {"mu": (0.1, 10.0)}
"""The fit's own ranges of the calibration scales (x nominal; the FRF files' far calibration, mu within a
decade), within what the configuration accepts (``fit_bounds``); all moved on a log scale."""
HALF_WIDTH = 0.12           # softening band: +-12 % around the mode (the rig's level lines)
CANDIDATES = ("micro_slip", CLAMP)
AFT_RATIO = 0.5             # method aft on the lines where df's normal ratio |g^_n| / |g_n0| of a closed pair reaches
#                             this, df's own solution on the others (``aft_where_open``)
AFT_MAX_ITER = 20           # Newton iterations of an "aft" start: converged lines take 1-9 on the lap joint; a start
#                             that fails (the continuation across a jump) then costs a third of the default 60, and
#                             gives the same FRFs there (2.4 instead of 6.5 s at 10 N)


def level_of(test: FRFTest) -> float:
    """The test's level: its force amplitude [N] (sidecar amplitude_n), or a drive-voltage test's drive
    amplitude [V] (drive_amplitude_v), or a random test's rms [N or V] (rt.discrepancy.diagnose.random_level);
    ValueError if the sidecar has none."""
    if is_random(test):
        return float(test.meta["random"]["rms"])
    key = "drive_amplitude_v" if test.excitation == "drive_voltage" else "amplitude_n"
    a = test.meta.get(key)
    if a is None:
        raise ValueError(f"{test.name}: sidecar {key} is missing; FRFs at several levels need each test's "
                         + ("drive amplitude in V" if key == "drive_amplitude_v" else "force amplitude in N"))
    return float(a)


def split(tests: list[FRFTest], calibrate_on) -> tuple[list[int], list[int]]:
    """(indices of the tests at the levels ``calibrate_on`` [N], the others). ValueError naming the
    levels when one matches no test, when all tests would be calibrated on, or when the folder has
    fewer than two levels or more than one bolt force."""
    levels = sorted({level_of(t) for t in tests})
    if len(levels) < 2:
        raise ValueError(f"the folder has one excitation level ({levels[0]:g} N); --calibrate-on needs FRFs at "
                         "two levels or more (rig --frf-files --levels)")
    if len({round(t.F_N1, 6) for t in tests}) > 1:
        raise ValueError("the folder's tests are at several bolt forces F_N1; --calibrate-on compares levels at one")
    want = [float(a) for a in calibrate_on]
    for a in want:
        if not any(math.isclose(a, b, rel_tol=1e-6) for b in levels):
            raise ValueError(f"--calibrate-on {a:g}: no test at that level; the folder's levels (N, or V for drive "
                             "voltages): " + ", ".join(f"{b:g}" for b in levels))
    cal = [i for i, t in enumerate(tests) if any(math.isclose(level_of(t), a, rel_tol=1e-6) for a in want)]
    rest = [i for i in range(len(tests)) if i not in cal]
    if not rest:
        raise ValueError("--calibrate-on names every level of the folder: leave at least one to predict")
    return cal, rest


def fit_bounds(nominal: Config) -> dict[str, tuple[float, float]]:
    """{parameter: (lo, hi)} of the harmonic-balance fit around ``nominal``: ``BOUNDS`` intersected with
    what the configuration accepts (rt.discrepancy.chain.scale_bounds), the force scale's [N/V]."""
    return {k: scale_bounds(nominal, k, *b) for k, b in BOUNDS.items()} | {FORCE_SCALE: FORCE_SCALE_N_PER_V}


def form_ranges(ranged: Config) -> dict[str, tuple[float, float]]:
    """The linear level model's plausible ranges (rt.discrepancy.diagnose.plausible.ranges of E, k_t and the
    modal damping) around ``ranged``, the nominal before a model form is held: a form's strength is not a
    calibration scale (a compliant joint held at s x the contact's k_t_area leaves k_t, the contact's own
    stiffness, around its literature range, not that range / s)."""
    return ranges(ranged, list(FRF_CAL_NAMES))


def mode_bands(d: FRFData) -> FRFData:
    """``d`` on the lines that carry the amplitude dependence: those within +-HALF_WIDTH of a measured mode
    (paired with the model's or not: ``f_modes``, ``unpaired_hz``), each in the band of its nearest mode;
    every fitted line's sigma_k divided by sqrt(w_b), w_b = n / (B n_b) (n_b the band's fitted lines of the
    sensor, B its bands with lines, n = sum_b n_b), so each band weighs the same in the sum of squares,
    sum_{k in b} w_b = n / B, however dense its lines. ``d`` itself if no mode was measured."""
    f_m = d.modes_hz
    if not len(f_m):
        return d
    near = np.argmin(np.abs(np.log(d.freq[:, None] / f_m[None, :])), axis=1)
    band = np.where(np.abs(d.freq / f_m[near] - 1.0) <= HALF_WIDTH, near, -1)
    keep = band >= 0
    sel, ln_h, sigma = {}, {}, {}
    for s, m0 in d.sel.items():
        sig = np.full(len(d.freq), np.nan)
        sig[m0] = d.sigma[s]
        m = m0 & keep
        n_b = np.bincount(band[m], minlength=len(f_m))
        w = m.sum() / (np.count_nonzero(n_b) * n_b[band[m]])
        sel[s], ln_h[s], sigma[s] = m[keep], np.log(np.abs(d.H[s][m])), sig[m] / np.sqrt(w)
    return d._replace(freq=d.freq[keep], H={s: h[keep] for s, h in d.H.items()}, sel=sel, ln_h=ln_h, sigma=sigma)


def _cfg(nominal: Config, theta: dict, effect: Effect | None) -> Config:
    cfg = scaled(nominal, {k: theta[k] for k in CAL_NAMES})
    return effect.apply(cfg, theta[effect.name]) if effect is not None else cfg


def nonlinear_H(cfg: Config, data: list[FRFData], levels: list[float], scale: float = 1.0,
                method: str = "df", details: list | None = None) -> list[dict]:
    """The harmonic balance's FRFs {sensor: H in the test's quantity, per newton or, for a drive-voltage
    test, per volt} (NaN where it has no solution) on every test's lines at its level (force amplitude
    [N], or drive amplitude [V] times the force scale ``scale`` [N/V]) by plant.harmonic_frf's ``method``
    ("df" or "aft", one start per line); ``cfg`` holds the sensors' points. ``details``: a list that gets
    each test's plant.harmonic_frf.HarmonicFRF (the pairs' slip and contact per line)."""
    model = build_plant(quiet(cfg))
    out, systems = [], {}
    for d, amp in zip(data, levels):
        key = (d.F_N1, tuple(sorted(d.points.items())))
        if key not in systems:
            systems[key] = harmonic_system(model, dict(d.points), F_N1=d.F_N1)
        g = scale if d.per_volt else 1.0
        r = (aft_where_open(systems[key], amp, g, d.freq) if method == "aft" else
             level_accelerances(systems[key], amp, g, d.freq, method=method, branches=False))
        if details is not None:
            details.append(r)
        out.append({s: g * from_accelerance(h, d.freq, d.quantity) for s, h in r.H.items()})
    return out


def aft_where_open(hs, amp: float, scale: float, freq_hz: np.ndarray):
    """Method aft's FRF (plant.harmonic_frf.HarmonicFRF) at level ``amp`` x ``scale`` [N] on the lines freq_hz
    [Hz], solved by aft only where it differs from df: df on every line first (one pass, ~1e-4 s a line), then
    aft (AFT_MAX_ITER Newton iterations a start) on the lines where a closed pair's normal ratio
    |g^_n| / |g_n0| reaches AFT_RATIO or df found no solution; df's solution on the others. Below a normal ratio
    of 1 no pair opens, and the slip limit mu f_n(t) swings by that ratio: on the aluminium lap joint at 7.4 N
    (400 lines of mode 2's region, benchmarks.levels_time's truth) aft and df differ by at most 0.001 dB where
    df's ratio stays below 0.5, 0.011 below 0.8, 0.020 below 1, and by up to 4.1 dB above it; on the default
    structure at 10 N (a compliant clamp and joint, micro_slip 0.5; 60 lines 50-1200 Hz) by up to 0.047 dB below
    0.5, one line (855 Hz, ratio 0.03) 0.17 dB, and up to 2.2 dB above it."""
    r = level_accelerances(hs, amp, scale, freq_hz, method="df", branches=False)
    ratio = np.max(np.where(r.closed[None, :], r.normal_ratio, 0.0), axis=1, initial=0.0)
    m = ~(ratio < AFT_RATIO)                  # NaN (no df solution) too
    if not m.any():
        return dataclasses.replace(r, method="aft")
    a = level_accelerances(hs, amp, scale, freq_hz[m], method="aft", branches=False, max_iter=AFT_MAX_ITER)
    out = {}
    for k in ("g_t", "g_n", "normal_ratio", "slip_amp_m", "open_fraction", "converged", "iterations", "residual",
              "n_solutions"):
        v = getattr(r, k).copy()
        v[m] = getattr(a, k)
        out[k] = v
    H = {s: np.where(m, 0.0, h) for s, h in r.H.items()}
    for s in H:
        H[s][m] = a.H[s]
    return dataclasses.replace(r, method="aft", H=H, **out)


def fit_label(effect: Effect | None) -> str:
    """The name of a harmonic-balance fit in the report and its progress bar."""
    return "harmonic balance" + (f" with {effect.name}" if effect else "")


def fit_nonlinear(nominal: Config, data: list[FRFData], levels: list[float], start: dict,
                  effect: Effect | None, method: str = "df", bars: bool = False, ranged: Config | None = None
                  ) -> dict:
    """Calibration (and the effect; and the force scale of drive-voltage tests) of the harmonic-balance
    model on ``data``, penalised outside the plausible ranges around ``ranged`` (default ``nominal``; the
    nominal before a model form was held, ``form_ranges``) (rt.discrepancy.diagnose.plausible): {"theta",
    "channels", "cfg", "evaluations"}. ``bars``: a tqdm bar on stderr over the model evaluations, with the best
    cost so far; Ctrl-C raises FitInterrupted with that best point (rt.discrepancy.diagnose.watch)."""
    per_volt = any(d.per_volt for d in data)
    logs = list(CAL_NAMES) + ([FORCE_SCALE] if per_volt else [])
    names = logs + ([effect.name] if effect else [])
    b = fit_bounds(nominal)
    span = effect.parameter.hi - effect.parameter.lo if effect else 1.0   # the effect moves as strength / span
    lo = [math.log(b[k][0]) for k in logs] + ([effect.parameter.lo / span] if effect else [])
    hi = [math.log(b[k][1]) for k in logs] + ([effect.parameter.hi / span] if effect else [])
    x0 = [math.log(start.get(k, 1.0)) for k in logs] + ([effect.parameter.default / span] if effect else [])
    x0 = np.clip(x0, np.array(lo) + 1e-9, np.array(hi) - 1e-9)

    def theta_of(x):
        return {k: (math.exp(v) if k in logs else float(v) * span) for k, v in zip(names, x)}

    def H_of(theta):
        return nonlinear_H(_cfg(nominal, theta, effect), data, levels, theta.get(FORCE_SCALE, 1.0), method)

    plausible = ranges(ranged if ranged is not None else nominal, names)

    def r(x):
        theta = theta_of(x)
        ch, _, _ = weighted_residuals(data, H_of(theta), profile_scale=False)
        v = np.concatenate(list(ch.values()))
        v = np.concatenate([v, penalty(names, theta.values(), plausible, len(v))])
        ev.seen(x, v)
        return v

    def point(x):
        return theta_of(x), _cfg(nominal, theta_of(x), effect)

    with watch(fit_label(effect), bars, point) as ev:
        sol = least_squares(r, x0, bounds=(lo, hi), diff_step=1e-3, x_scale=1.0, max_nfev=60)
    theta = theta_of(sol.x)
    return {"theta": theta, "channels": weighted_residuals(data, H_of(theta), profile_scale=False)[0],
            "cfg": _cfg(nominal, theta, effect), "evaluations": int(sol.nfev)}


def calibration_gap(linear: dict, nonlinear: dict) -> dict:
    """The two models at the calibration levels by the objective both are fitted on: the rms of the
    weighted residuals (ln|H_meas| - ln|H_model|) / sigma_k over the modes' bands' lines (``mode_bands``;
    1 is the noise), from their channels ``linear`` and ``nonlinear``. The harmonic balance with its
    joints closed and stuck is the linear model, so its best fit can be no worse than the linear one:
    a fit that ends worse stopped in another valley or at its bounds (mu cannot reach the stuck limit
    within the configuration's range), and is refused, the stuck limit kept ("refused": True)."""
    rms = [float(np.sqrt(np.mean(np.concatenate(list(ch.values())) ** 2))) for ch in (linear, nonlinear)]
    return {"measure": "rms of (ln|H_meas| - ln|H_model|) / sigma_k over the modes' bands at the calibration levels",
            "linear": round(rms[0], 4), "nonlinear": round(rms[1], 4), "refused": rms[1] > rms[0]}


def gap_db(d: FRFData, h: dict, band: tuple[float, float] | None) -> float:
    """RMS of 20 log10|H_meas / H_model| over the lines in ``band`` [Hz] (None: all), every sensor [dB]."""
    e = []
    for s in d.sel:
        m = (d.freq >= band[0]) & (d.freq <= band[1]) if band else np.ones(len(d.freq), bool)
        e.append(20.0 * np.log10(np.abs(d.H[s][m]) / np.abs(h[s][m])))
    e = np.concatenate(e)
    return round(float(np.sqrt(np.nanmean(e ** 2))), 4)


def softening_band(nominal: Config, data: list[FRFData], levels: list[float]) -> tuple[float, float, int]:
    """(low, high [Hz], mode number): +-HALF_WIDTH around the stuck model's mode whose measured peak
    (first sensor, in that band) moves most from the lowest to the highest level."""
    lo_i, hi_i = int(np.argmin(levels)), int(np.argmax(levels))
    f_modes = undamped_frequencies(build_plant(quiet(nominal)), data[lo_i].F_N1)
    best = None
    for j, fm in enumerate(f_modes):
        band = (fm * (1 - HALF_WIDTH), fm * (1 + HALF_WIDTH))
        peaks = []
        for i in (lo_i, hi_i):
            d = data[i]
            s = next(iter(d.sel))
            m = (d.freq >= band[0]) & (d.freq <= band[1])
            if m.sum() < 3:
                break
            peaks.append(d.freq[m][np.argmax(np.abs(d.H[s][m]))])
        if len(peaks) == 2 and (best is None or abs(peaks[1] / peaks[0] - 1) > best[0]):
            best = (abs(peaks[1] / peaks[0] - 1), band, j + 1)
    if best is None:
        raise ValueError("no mode of the model has three measured lines or more within +-12 %: the levels' "
                         "lines do not cover a resonance")
    return best[1][0], best[1][1], best[2]


def contact_of(r) -> dict:
    """A level's contact in the harmonic balance r (plant.harmonic_frf.HarmonicFRF), over its lines and
    closed pairs: the largest normal ratio |g^_n| / |g_n0| (> 1: the contact opens and closes in the
    cycle) and the largest fraction of the period a pair is open (df: 0, it keeps them closed)."""
    return {"normal_ratio_max": round(float(np.nanmax(r.normal_ratio[:, r.closed], initial=0.0)), 3),
            "open_fraction_max": round(float(np.nanmax(r.open_fraction[:, r.closed], initial=0.0)), 3)}


def contact_note(pred: list[dict], method: str, unit: str, random: bool = False) -> str | None:
    """The report's note for method df where the prediction rows ``pred`` (``contact_of`` keys, level_n in
    ``unit``; None where the stuck limit was kept) have a normal ratio above 1; None for aft or a joint that
    stays closed. ``random``: the levels are
    random tests (rt.discrepancy.diagnose.random_level: the ratio of the normal gap's rms-equivalent sine)."""
    gaping = [g["level_n"] for g in pred if (g["normal_ratio_max"] or 0.0) > 1.0]
    if method != "df" or not gaping:
        return None
    if random:
        return (f"at {', '.join(f'{a:g}' for a in gaping)} {unit} rms a closed pair's normal gap (its rms x sqrt(2)) "
                "swings more than its static gap: the contact opens and closes, which the random tests' "
                "linearisation keeps linear (no method of --calibrate-on holds it for random tests yet)")
    text = (f"at {', '.join(f'{a:g}' for a in gaping)} {unit} a closed pair's normal gap swings more than its static "
            "gap (normal ratio > 1): the contact opens and closes in the cycle, which method df keeps linear; "
            "--harmonic-method aft holds it")
    if any("gap_aft_db" in g for g in pred):
        text += (" (predicted there by aft from this calibration: gap_aft_db; a calibration by aft costs several "
                 "times df's per model evaluation, so it runs only when asked)")
    return text


def diagnose_levels(folder: str | Path, calibrate_on, nominal: Config | None = None, progress=None,
                    method: str = "df", bars: bool = False, form: dict[str, float] | None = None) -> dict:
    """The workflow (module docstring) on a folder of FRF files at several levels, the harmonic balance
    by ``method`` (METHODS); a JSON-ready dict with the calibrated configuration under "_config" and
    plotting data under "_plots". ``progress(msg)``: the stages; ``bars``: tqdm bars on stderr inside the
    harmonic-balance fits. ``form``: a model form known beforehand, {candidate name: strength}
    (rt.discrepancy.effects, ``Effect.form``), held in both level models as the form stage holds the one it
    names (rt.discrepancy.diagnose.levels_form; the form stage is not run). Ctrl-C raises Interrupted with the
    fits done so far (rt.discrepancy.diagnose.watch). ValueError for a name in ``form`` that is not a model
    form."""
    if method not in METHODS:
        raise ValueError(f"harmonic-balance method {method!r}: expected one of {', '.join(METHODS)}")
    with threadpool_limits(1):
        return _diagnose_levels(folder, calibrate_on, nominal, progress or (lambda msg: None), method, bars, form)


def _diagnose_levels(folder, calibrate_on, nominal: Config | None, say, method: str, bars: bool,
                     form: dict[str, float] | None = None) -> dict:
    nominal = nominal if nominal is not None else with_sets(Config(), [])
    for name in form or {}:
        if name not in {e.name for e in form_candidates(nominal)}:
            raise ValueError(f"model form {name!r} is not a model-form candidate of this structure; give one of "
                             + ", ".join(e.name for e in form_candidates(nominal)))
    tests = load_frf_folder(folder)
    broadband = [t for t in tests if t.meta.get("broadband")]    # beside the levels: the form stage's data
    tests = [t for t in tests if not t.meta.get("broadband")]
    cal, rest = split(tests, calibrate_on)
    levels = [level_of(t) for t in tests]
    if len({t.excitation for t in tests}) > 1:
        raise ValueError(f"{folder}: the tests mix force and drive-voltage excitation; --calibrate-on takes one kind")
    try:
        data = prepare(tests, nominal)
        wide = prepare(broadband, nominal) if broadband else []
        nominal, _ = with_sensor_points(tests, nominal)
        levels = random_levels(tests, data, levels, HALF_WIDTH, nominal)
        if method != "df" and any(isinstance(a, RandomLevel) for a in levels):
            raise ValueError(f"--harmonic-method {method}: a random test is the joint's equivalent linearisation "
                             "under a Gaussian gap, of the pairs' tangential law with the normal contact linear "
                             "(rt/discrepancy/diagnose/random_level.py); give --harmonic-method df")
    except ValueError as exc:
        raise ValueError(f"{folder}: {exc}") from None
    with keeping({}, input="frf_levels", calibrate_on_n=[levels[i] for i in cal], harmonic_method=method) as done:
        return _calibrate_and_predict(nominal, data, levels, cal, say, method, bars, done, form, wide)


def _calibrate_and_predict(nominal: Config, data: list[FRFData], levels: list[float], cal: list[int], say,
                           method: str, bars: bool, done: dict, given: dict[str, float] | None = None,
                           wide: list[FRFData] | None = None) -> dict:
    """The fits and the prediction of ``_diagnose_levels``; each fit, once done, also into ``done``
    {name: {"fitted", "cfg", ...}} (what an interruption keeps). ``given``: the known model form; ``wide``: the
    broadband tests beside the levels (the form stage's data, all their lines, where there are any)."""
    dc, lc = [data[i] for i in cal], [levels[i] for i in cal]
    db = [mode_bands(d) for d in dc]
    lines = sum(len(d.freq) for d in db)
    ranged = nominal         # the plausible ranges: of the nominal before a form is held (``form_ranges``)
    say(f"linear model, calibrated at {', '.join(f'{a:g}' for a in lc)} N on {lines} lines of the modes' bands")
    lin = fit(nominal, db, None, bars=bars, label="linear")
    done["linear"] = done_fit(lin.theta, lin.cfg)
    if given:
        form = {"tried": [], "named": list(given), "strengths": dict(given), "ranking": [], "second_round": None,
                "points_at": None, "mode": "given", "reason": None,
                "nominal": corrected(nominal, given)}
    else:
        form = (fit_form(nominal, wide, say, bars, done, on="the broadband test") if wide else
                fit_form(nominal, [b for b, a in zip(db, lc) if a == min(lc)], say, bars, done))
        form["on"] = ", ".join(d.name for d in wide) if wide else "the lowest calibration level"
    lin_nominal_form = None
    if form["named"]:        # both level models from the corrected form (rt.discrepancy.diagnose.levels_form)
        lin_nominal_form, nominal = lin, form["nominal"]
        say(f"linear model with the model form {' and '.join(form['named'])} held")
        lin = fit(nominal, db, None, plausible=form_ranges(ranged), bars=bars, label="linear, model form held")
        done["linear, model form held"] = done_fit(lin.theta, lin.cfg)
    H_lin = model_H(lin.cfg, data)
    start = {k: lin.theta[k] for k in ("E", "k_t", "modal_damping", FORCE_SCALE) if k in lin.theta}
    say(f"harmonic balance ({method}), calibration only, on the same lines")
    fits = {}
    candidates = [get(n) for n in CANDIDATES if n not in form["named"]]    # a form held is not fitted again
    for eff in [None, *candidates]:
        if eff is not None:
            say(fit_label(eff))
        fits[eff] = fit_nonlinear(nominal, db, lc, fits[None]["theta"] if eff else start, eff, method, bars,
                                  **({"ranged": ranged} if form["named"] else {}))   # without a form: nominal's
        done[fit_label(eff)] = done_fit(fits[eff]["theta"], fits[eff]["cfg"], evaluations=fits[eff]["evaluations"])
    results = [{"effect": e.name if e else None, "theta": f["theta"], "channels": f["channels"],
                "score": bic(f["channels"], len(f["theta"])), "cfg": f["cfg"]} for e, f in fits.items()]
    base, ranked, winner = rank(results)
    final = winner or base
    calibration = calibration_gap(lin.channels, final["channels"])
    if calibration["refused"]:
        winner, final = None, None
    winner_effect = next((e for e in fits if winner and e is not None and e.name == winner["effect"]), None)
    per_volt = any(d.per_volt for d in data)
    plausible = ranges(ranged, [*CAL_NAMES, CLAMP])
    plausibility = verdict(plausible, fits[None]["theta"], (final or base)["theta"], (final or base)["effect"],
                           [e.name for e in candidates]) | {"linear_outside": outside(lin.theta, plausible)}
    say("prediction at the other levels")
    hb = []
    H_lin = [{s: h * lin.theta.get(FORCE_SCALE, 1.0) if d.per_volt else h for s, h in hs.items()}
             for d, hs in zip(data, H_lin)]
    if final is not None:
        H_nl = nonlinear_H(final["cfg"], data, levels, final["theta"].get(FORCE_SCALE, 1.0), method, hb)
    else:    # the stuck limit: the linear model (the joint's contact closed and stuck in the harmonic balance)
        H_nl = H_lin
    band = softening_band(nominal, data, levels)
    H_nf = None
    if lin_nominal_form is not None:   # the linear model of the nominal form, for comparison
        H_nf = [{s: h * lin_nominal_form.theta.get(FORCE_SCALE, 1.0) if d.per_volt else h for s, h in hs.items()}
                for d, hs in zip(data, model_H(lin_nominal_form.cfg, data))]
    pred = []
    for i, (d, a) in enumerate(zip(data, levels)):
        g = {"test": d.name, "level_n": a, "calibrated_on": i in cal,
             "gap_linear_db": gap_db(d, H_lin[i], band[:2]), "gap_nonlinear_db": gap_db(d, H_nl[i], band[:2]),
             "gap_linear_all_db": gap_db(d, H_lin[i], None), "gap_nonlinear_all_db": gap_db(d, H_nl[i], None)}
        if H_nf is not None:
            g |= {"gap_linear_nominal_form_db": gap_db(d, H_nf[i], band[:2]),
                  "gap_linear_nominal_form_all_db": gap_db(d, H_nf[i], None)}
        g["ratio"] = round(g["gap_linear_db"] / g["gap_nonlinear_db"], 3) if g["gap_nonlinear_db"] > 0 else None
        g["better"] = "nonlinear" if g["gap_nonlinear_db"] < g["gap_linear_db"] else "linear"
        pred.append(g | (contact_of(hb[i]) if hb else {"normal_ratio_max": None, "open_fraction_max": None}))
    gaping = [i for i, g in enumerate(pred) if (g["normal_ratio_max"] or 0.0) > 1.0]
    if method == "df" and final is not None and gaping and not any(isinstance(a, RandomLevel) for a in levels):
        say(f"prediction by method aft where the contact opens ({len(gaping)} levels), from this calibration")
        H_aft = nonlinear_H(final["cfg"], [data[i] for i in gaping], [levels[i] for i in gaping],
                            final["theta"].get(FORCE_SCALE, 1.0), "aft")
        for i, h in zip(gaping, H_aft):
            pred[i] |= {"gap_aft_db": gap_db(data[i], h, band[:2]), "gap_aft_all_db": gap_db(data[i], h, None)}
    stuck = final is None
    final = final or {"theta": lin.theta, "cfg": lin.cfg, "effect": None}
    return {"input": "frf_levels", "calibrate_on_n": lc, "levels_n": sorted(set(levels)),
            "level_unit": "V" if any(d.per_volt for d in data) else "N", "harmonic_method": method,
            "softening_band_hz": [round(band[0], 2), round(band[1], 2)], "softening_mode": band[2],
            "named_effect": winner["effect"] if winner else None,
            "ranking": [{"effect": r["effect"], "delta_bic": round(base["score"] - r["score"], 2),
                         "rss_reduction": round(r["rss_reduction"], 4),
                         "fitted": rounded(r["theta"])} for r in ranked],
            "model_form": {k: v for k, v in form.items() if k != "nominal"} | (
                {"linear_nominal_form": {"fitted": rounded(lin_nominal_form.theta)}} if lin_nominal_form else {}),
            "linear": {"fitted": rounded(lin.theta)},
            "nonlinear": {"fitted": rounded(final["theta"]), "stuck_limit": stuck,
                          "evaluations": fits[None]["evaluations"],
                          "lines": {d.name: [len(b.freq), len(d.freq)] for d, b in zip(dc, db)}},
            "calibration_gap": calibration,
            "prediction": pred,
            "contact_note": contact_note(pred, method, "V" if per_volt else "N",
                                         any(isinstance(a, RandomLevel) for a in levels)),
            "plausibility": plausibility,
            "warnings": [w | {"model": "linear"} for w in bound_warnings(lin.theta, None, per_volt, nominal)]
                        + ([] if stuck else [w | {"model": "harmonic balance"} for w in bound_warnings(
                            final["theta"], winner_effect, per_volt, nominal, fit_bounds(nominal))]),
            "_config": final["cfg"],
            "_plots": [(d.name, a, d.freq, d.H, h0, h1) for d, a, h0, h1 in zip(data, levels, H_lin, H_nl)]}
