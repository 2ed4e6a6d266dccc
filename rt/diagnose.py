"""The discrepancy workflow (issue 7, docs/discrepancy.md): where do model and measurement
disagree, which effect of the library (rt.effects) is missing, and how much of the gap it closes.

Method, on a campaign of the measurement format (impulse tests at several F_N1, actuator ramps):

1. Features. Impulse tests: the accelerance H = a_frf / F_exc (exponential window, plant.impulse)
   and per mode m of ``MODES`` its natural frequency f_m and damping ratio zeta_m (plant.impulse.
   identify), at each F_N1 (the measured bolt force). Actuator tests: the time series V_a, i and
   F_cell. The model side is the same chain (rt.rig.measure_impulse / measure_actuator, noise off)
   driven by the measured F_exc, resp. the recorded V_cmd.
2. Calibration and candidates. Parameters: calibration scales of E, modal damping, mu, k_t
   (structure) and c_v (actuator), plus the strength of one candidate effect. Structure: the
   feature vector is linearised around the nominal model by finite differences (one model run per
   parameter), the weighted residuals
       r = [(f_meas - f_model) / f_meas / SIGMA_F,  (zeta_meas - zeta_model) / zeta_meas / SIGMA_ZETA]
   are minimised by bounded linear least squares (scipy.optimize.lsq_linear) for calibration alone
   and for calibration + each structural candidate, then refined by ``REFINE`` chord steps with the
   exact model (same Jacobian, exact residual). Actuator: bounded nonlinear least squares
   (scipy.optimize.least_squares) on the exact chain, residuals per signal divided by the signal's
   noise rms estimated on the record's first 2 ms at rest.
3. Ranking by BIC = sum over channels c of n_c ln(RSS_c / n_c) + p ln n (channels: frequencies,
   damping ratios, V_a, i, F_cell; p the fitted parameters, n all residuals), i.e. the Gaussian
   likelihood with one variance per channel. The best candidate is named only if its BIC is below
   calibration alone by more than ``NAME_THRESHOLD`` (= 10, "very strong" on Kass & Raftery's
   scale); the runner-up is reported.
4. The updated model (calibrated, with the named effect) is written as a TOML (rt.config.dumps),
   the gap before (nominal) and after is measured on the raw data: FRF log-magnitude RMS [dB] over
   ``BAND_HZ`` per impulse test, time-series NRMSE of a_frf (impulse) and F_cell (actuator).
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from mcap.reader import make_reader
from scipy.optimize import least_squares, lsq_linear

from plant.impulse import accelerance_frf, identify
from plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from rt.config import Config, with_sets
from rt.effects import Effect, implemented
from rt.mcap_log import read_mcap
from rt.rig import hold_voltage, measure_actuator, measure_impulse, quiet, scaled

MODES = (2, 3, 4, 5)             # bending modes identified in the impulse tests (mode 6 at ~1 kHz: unreliable)
BAND_HZ = (50.0, 1200.0)         # FRF gap band [Hz]
SIGMA_F = 1e-3                   # frequency residual scale (relative)
SIGMA_ZETA = 0.05                # damping residual scale (relative)
NAME_THRESHOLD = 10.0            # BIC margin over calibration alone to name an effect
REFINE = 2                       # exact chord steps after the linearised fit
REST_S = 2e-3                    # actuator records start with this long at rest (noise estimate)

STRUCT_CAL = {"E": (0.02, 0.9, 1.1), "mu": (0.1, 0.6, 1.4), "k_t": (0.1, 0.6, 1.4)}
"""Structure calibration scales fitted with each candidate on the frequencies: (finite-difference
step, lower, upper bound) around 1."""
DAMPING_CAL = (0.2, 0.3, 3.0)
"""modal_damping scale, fitted once on the damping ratios (no candidate of the library changes them)."""
ACT_CAL = {"c_v": (0.8, 1.2)}


class Test(NamedTuple):
    name: str
    kind: str
    dt: float
    data: dict          # signal name -> array (n,)


def read_test_record(path: Path) -> dict:
    with open(path, "rb") as f:
        for m in make_reader(f).iter_metadata():
            if m.name == "test":
                return dict(m.metadata)
    return {}


def load_campaign(folder: str | Path) -> list[Test]:
    """The impulse and actuator tests of a campaign folder (every *.mcap). ValueError naming the
    folder or file on a problem."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"{folder}: {'not a folder' if folder.exists() else 'no such folder'}; give a "
                         "campaign folder (frictionrt rig -o DIR writes one)")
    files = sorted(folder.glob("*.mcap"))
    if not files:
        raise ValueError(f"{folder}: no *.mcap measurement files in the folder")
    tests = []
    for p in files:
        log = read_mcap(p)
        kind = read_test_record(p).get("kind")
        names = [n for n, _, _ in log.signals]
        need = ("F_exc", "a_frf_meas", "F_cell") if kind == "impulse" else ("V_cmd", "V_a", "i", "F_cell")
        if kind not in ("impulse", "actuator"):
            continue
        miss = [n for n in need if n not in names]
        if miss:
            raise ValueError(f"{p}: {kind} test without {', '.join(miss)}; the workflow needs them "
                             "(docs/discrepancy.md)")
        data = {n: log.log[:, i] for i, n in enumerate(names)}
        if not all(np.all(np.isfinite(data[n])) for n in need) or len(log.k) < 64:
            raise ValueError(f"{p}: gaps, NaN or fewer than 64 ticks in the needed channels; "
                             "check it with frictionrt validate")
        tests.append(Test(p.stem, kind, 1.0 / log.rate_hz, data))
    if not any(t.kind == "impulse" for t in tests):
        raise ValueError(f"{folder}: no impulse test (test.kind = impulse) among {len(files)} files")
    return tests


# --- features -------------------------------------------------------------------------------------

def _fn1(t: Test) -> float:
    return float(np.mean(t.data["F_cell"]))


def frf(t: Test, a: np.ndarray):
    """(freq [Hz], H) of accelerance a / F_exc with the window of plant.impulse (tau = T / 4)."""
    tau = len(a) * t.dt / 4.0
    return accelerance_frf(t.data["F_exc"], a, t.dt, tau)


def modal_features(t: Test, a: np.ndarray, approx_hz: np.ndarray):
    """(f_n [Hz], zeta [-]) of ``MODES`` identified from F_exc and a."""
    freq, H = frf(t, a)
    return identify(freq, H, approx_hz, len(a) * t.dt / 4.0)


class StructureRun(NamedTuple):
    f: np.ndarray         # (tests, modes) [Hz]
    zeta: np.ndarray      # (tests, modes)
    a: list               # model a_frf per test


def run_structure(cfg: Config, tests: list[Test], approx: list[np.ndarray]) -> StructureRun:
    """The model of ``cfg`` (noise off) on each impulse test's measured F_exc and bolt force."""
    model = build_plant(quiet(cfg))
    f, z, a = [], [], []
    for t, ap in zip(tests, approx):
        ch = measure_impulse(model, t.data["F_exc"], hold_voltage(cfg, _fn1(t)), seed=0)
        fn, zeta = modal_features(t, ch["a_frf_meas"], ap)
        f.append(fn)
        z.append(zeta)
        a.append(ch["a_frf_meas"])
    return StructureRun(np.array(f), np.array(z), a)


def run_actuator_tests(cfg: Config, tests: list[Test]) -> list[dict]:
    return [measure_actuator(quiet(cfg), t.data["V_cmd"], seed=0) for t in tests]


# --- gap metrics ----------------------------------------------------------------------------------

def frf_gap_db(t: Test, a_model: np.ndarray) -> float:
    """RMS of 20 log10 |H_meas / H_model| over BAND_HZ [dB]."""
    freq, Hm = frf(t, t.data["a_frf_meas"])
    _, Hs = frf(t, a_model)
    sel = (freq >= BAND_HZ[0]) & (freq <= BAND_HZ[1])
    return float(np.sqrt(np.mean((20 * np.log10(np.abs(Hm[sel]) / np.abs(Hs[sel]))) ** 2)))


def nrmse(meas: np.ndarray, model: np.ndarray) -> float:
    """||meas - model|| / ||meas - mean(meas)||."""
    return float(np.linalg.norm(meas - model) / np.linalg.norm(meas - np.mean(meas)))


def gaps(imp: list[Test], act: list[Test], srun: StructureRun, aruns: list[dict]) -> dict:
    """Gap metrics per test and their summaries (mean FRF dB over impulse tests, mean NRMSE)."""
    out = {}
    for t, a in zip(imp, srun.a):
        out[t.name] = {"frf_db": round(frf_gap_db(t, a), 4), "nrmse_a_frf": round(nrmse(t.data["a_frf_meas"], a), 5)}
    for t, r in zip(act, aruns):
        out[t.name] = {"nrmse_F_cell": round(nrmse(t.data["F_cell"], r["F_cell"]), 5),
                       "nrmse_V_a": round(nrmse(t.data["V_a"], r["V_a"]), 5)}
    out["structure_frf_db"] = round(float(np.mean([out[t.name]["frf_db"] for t in imp])), 4)
    out["actuator_nrmse"] = round(float(np.mean([out[t.name]["nrmse_F_cell"] for t in act])), 5) if act else None
    return out


# --- structure fit --------------------------------------------------------------------------------

def _struct_residual(meas_f, meas_z, run: StructureRun, mask) -> tuple[np.ndarray, np.ndarray]:
    """Weighted frequency and damping residuals of the modes identified in the measurement and the
    nominal model (mask); a mode the model run could not identify counts 0 (not NaN)."""
    rf = ((meas_f - run.f) / meas_f / SIGMA_F)[mask]
    rz = ((meas_z - run.zeta) / meas_z / SIGMA_ZETA)[mask]
    return np.nan_to_num(rf), np.nan_to_num(rz)


def _struct_cfg(nominal: Config, theta: dict, effect: Effect | None) -> Config:
    cfg = scaled(nominal, {k: theta[k] for k in (*STRUCT_CAL, "modal_damping") if k in theta})
    if "c_v" in theta:
        cfg = scaled(cfg, {"c_v": theta["c_v"]})
    if effect is not None and effect.name in theta:
        cfg = effect.apply(cfg, float(theta[effect.name]))
    return cfg


# --- actuator fit ---------------------------------------------------------------------------------

def _act_residuals(tests: list[Test], runs: list[dict], noise: dict) -> dict[str, np.ndarray]:
    return {s: np.concatenate([(t.data[s] - r[s]) / noise[s] for t, r in zip(tests, runs)])
            for s in ("V_a", "i", "F_cell")}


def _act_noise(tests: list[Test]) -> dict[str, float]:
    """Noise rms of V_a, i, F_cell on each record's first REST_S (command at rest)."""
    n = max(8, int(REST_S / tests[0].dt) - 4)
    return {s: max(float(np.mean([np.std(t.data[s][:n]) for t in tests])), 1e-9) for s in ("V_a", "i", "F_cell")}


def fit_actuator(nominal: Config, tests: list[Test], effect: Effect | None):
    """Bounded least squares of c_v (and the effect's strength) on the exact chain. Returns
    (theta, residuals by channel)."""
    noise = _act_noise(tests)
    names = ["c_v"] + ([effect.name] if effect else [])
    lo = [ACT_CAL["c_v"][0]] + ([effect.parameter.lo] if effect else [])
    hi = [ACT_CAL["c_v"][1]] + ([effect.parameter.hi] if effect else [])

    def cfg_of(x):
        cfg = scaled(nominal, {"c_v": x[0]})
        return effect.apply(cfg, float(x[1])) if effect else cfg

    def res(x):
        return np.concatenate(list(_act_residuals(tests, run_actuator_tests(cfg_of(x), tests), noise).values()))

    best = None
    starts = [[1.0]] if effect is None else [[1.0, effect.parameter.default * f] for f in (0.5, 2.0)]
    for x0 in starts:
        sol = least_squares(res, x0, bounds=(lo, hi), x_scale=[0.05] + ([effect.parameter.default * 0.2] if effect else []),
                            diff_step=[1e-3] + ([1e-2] if effect else []), max_nfev=40)
        if best is None or sol.cost < best.cost:
            best = sol
    theta = dict(zip(names, map(float, best.x)))
    return theta, _act_residuals(tests, run_actuator_tests(cfg_of(best.x), tests), noise)


# --- the workflow ---------------------------------------------------------------------------------

def bic(channels: dict[str, np.ndarray], p: int) -> float:
    """sum_c n_c ln(RSS_c / n_c) + p ln(n)."""
    n = sum(len(r) for r in channels.values())
    return float(sum(len(r) * math.log(max(float(r @ r), 1e-300) / len(r)) for r in channels.values() if len(r))
                 + p * math.log(n))


def diagnose(folder: str | Path, nominal: Config | None = None, progress=None) -> dict:
    """Run the workflow on a campaign folder; the result dict (docs/discrepancy.md) with the fitted
    configuration under "_config" and the plotting data under "_plots"."""
    say = progress or (lambda msg: None)
    nominal = nominal if nominal is not None else with_sets(Config(), [])
    tests = load_campaign(folder)
    imp = [t for t in tests if t.kind == "impulse"]
    act = [t for t in tests if t.kind == "actuator"]
    # --- measured features; approximate frequencies from the nominal linearised model
    m0 = build_plant(nominal)
    approx = [np.array([stuck_frequencies_hz(m0, preloaded_pairs(m0, _fn1(t)))[m - 1] for m in MODES]) for t in imp]
    meas = [modal_features(t, t.data["a_frf_meas"], ap) for t, ap in zip(imp, approx)]
    meas_f = np.array([m[0] for m in meas])
    meas_z = np.array([m[1] for m in meas])
    approx = [np.where(np.isfinite(f), f, ap) for f, ap in zip(meas_f, approx)]
    say("nominal model")
    theta0 = {k: 1.0 for k in STRUCT_CAL}
    run0 = run_structure(nominal, imp, approx)
    mask = np.isfinite(meas_f) & np.isfinite(meas_z) & np.isfinite(run0.f) & np.isfinite(run0.zeta)
    arun0 = run_actuator_tests(nominal, act)
    gap_before = gaps(imp, act, run0, arun0)
    # --- structure Jacobian (finite differences), calibration and candidate columns
    struct_eff = [e for e in implemented() if e.channel == "structure"]
    act_eff = [e for e in implemented() if e.channel == "actuator"]
    cols = {}
    steps = {k: v[0] for k, v in STRUCT_CAL.items()} | {e.name: e.parameter.default * 0.5 for e in struct_eff}
    rf0, rz0 = _struct_residual(meas_f, meas_z, run0, mask)
    say("sensitivity modal_damping")
    run = run_structure(_struct_cfg(nominal, theta0 | {"modal_damping": 1.0 + DAMPING_CAL[0]}, None), imp, approx)
    zcol = (rz0 - _struct_residual(meas_f, meas_z, run, mask)[1]) / DAMPING_CAL[0]
    zeta_scale = 1.0 + float(lsq_linear(zcol[:, None], rz0, bounds=(DAMPING_CAL[1] - 1.0, DAMPING_CAL[2] - 1.0)).x[0])
    theta0 = theta0 | {"modal_damping": zeta_scale}
    for name, h in steps.items():
        say(f"sensitivity {name}")
        eff = next((e for e in struct_eff if e.name == name), None)
        th = dict(theta0) | ({name: theta0[name] + h} if eff is None else {name: h})
        run = run_structure(_struct_cfg(nominal, th, eff), imp, approx)
        cols[name] = (rf0 - _struct_residual(meas_f, meas_z, run, mask)[0]) / h   # d(model)/d(theta)
    candidates = [None] + struct_eff + act_eff
    struct_fits = {}

    def fit_structure(eff):
        """Calibration (+ a structural candidate): linearised bounded fit on the frequencies, then
        REFINE exact chord steps."""
        snames = list(STRUCT_CAL) + ([eff.name] if eff else [])
        lo = [STRUCT_CAL[k][1] - 1.0 for k in STRUCT_CAL] + ([eff.parameter.lo] if eff else [])
        hi = [STRUCT_CAL[k][2] - 1.0 for k in STRUCT_CAL] + ([eff.parameter.hi] if eff else [])
        J = np.column_stack([cols[k] for k in snames])
        x = np.zeros(len(snames))
        r = rf0
        for _ in range(1 + REFINE):
            x = x + lsq_linear(J, r, bounds=(np.array(lo) - x, np.array(hi) - x)).x
            th = {k: (1.0 + v if k in STRUCT_CAL else v) for k, v in zip(snames, x)} | {"modal_damping": zeta_scale}
            run = run_structure(_struct_cfg(nominal, th, eff), imp, approx)
            r, rz = _struct_residual(meas_f, meas_z, run, mask)
        return th, r, rz, run

    results, act_fits = [], {}
    for eff in candidates:
        say(f"fit {eff.name if eff else 'calibration only'}")
        s_eff = eff if eff in struct_eff else None
        if s_eff not in struct_fits:
            struct_fits[s_eff] = fit_structure(s_eff)
        th, rf, rz, run = struct_fits[s_eff]
        a_eff = eff if eff in act_eff else None
        if a_eff not in act_fits:
            act_fits[a_eff] = fit_actuator(nominal, act, a_eff) if act else ({}, {})
        ath, ares = act_fits[a_eff]
        theta = th | ath
        channels = {"frequency": rf} | {f"actuator {k}": v for k, v in ares.items()}
        p = len(theta)
        cfg = _struct_cfg(nominal, theta, eff)
        results.append({"effect": eff.name if eff else None, "theta": theta, "channels": channels,
                        "score": bic(channels, p), "run": run, "cfg": cfg})
    base = results[0]
    ranked = sorted(results[1:], key=lambda r: r["score"])
    winner = ranked[0] if ranked and base["score"] - ranked[0]["score"] > NAME_THRESHOLD else None
    final = winner or base
    say("gap after")
    arun1 = run_actuator_tests(final["cfg"], act)
    gap_after = gaps(imp, act, final["run"], arun1)
    gap_cal = gaps(imp, act, base["run"], run_actuator_tests(base["cfg"], act))

    def feat_gap(res):
        return round(float(np.sqrt(np.mean(np.concatenate(list(res["channels"].values())) ** 2))), 4)

    ranking = [{"effect": r["effect"], "score": round(r["score"], 2), "delta_bic": round(base["score"] - r["score"], 2),
                "gap_after": feat_gap(r), "fitted": {k: float(f"{v:.5g}") for k, v in r["theta"].items()}}
               for r in ranked]
    localise = {t.name: {"F_N1_N": round(_fn1(t), 1),
                         "modes": {str(m): {"f_meas_hz": _r(meas_f[i, j]), "f_model_hz": _r(run0.f[i, j]),
                                            "shift_rel": _r((meas_f[i, j] - run0.f[i, j]) / run0.f[i, j], 6),
                                            "zeta_meas": _r(meas_z[i, j], 6), "zeta_model": _r(run0.zeta[i, j], 6)}
                                   for j, m in enumerate(MODES)}} for i, t in enumerate(imp)}
    for t, r in zip(act, arun0):
        localise[t.name] = {"i_peak_meas_A": _r(np.max(np.abs(t.data["i"])), 4),
                            "i_peak_model_A": _r(np.max(np.abs(r["i"])), 4),
                            "slew_meas_V_per_us": _r(_slew(t.data["V_a"], t.dt), 4),
                            "slew_model_V_per_us": _r(_slew(r["V_a"], t.dt), 4),
                            "F_per_V_meas": _r(_gain(t.data["V_a"], t.data["F_cell"]), 4),
                            "F_per_V_model": _r(_gain(r["V_a"], r["F_cell"]), 4)}
    fitted = {k: float(f"{v:.6g}") for k, v in final["theta"].items()}
    return {"named_effect": winner["effect"] if winner else None,
            "runner_up": (ranked[1]["effect"] if winner and len(ranked) > 1 else ranked[0]["effect"]) if ranked else None,
            "ranking": ranking, "calibration_only": {"score": round(base["score"], 2), "gap_after": feat_gap(base),
                                                     "fitted": {k: float(f"{v:.5g}") for k, v in base["theta"].items()}},
            "threshold_delta_bic": NAME_THRESHOLD, "gap_before": gap_before, "gap_calibrated": gap_cal,
            "gap_after": gap_after, "fitted_parameters": fitted, "localisation": localise,
            "not_tried": [e for e in _unimplemented()],
            "_config": final["cfg"],
            "_plots": {"imp": imp, "act": act, "before": (run0, arun0), "after": (final["run"], arun1)}}


def _unimplemented() -> list[str]:
    from rt.effects import EFFECTS
    return [n for n, e in EFFECTS.items() if not e.implemented]


def _r(x, nd=3):
    x = float(x)
    return round(x, nd) if math.isfinite(x) else None


def _slew(V: np.ndarray, dt: float) -> float:
    """Largest |dV/dt| over 4-tick differences [V/us]."""
    return float(np.max(np.abs(V[4:] - V[:-4])) / (4 * dt) * 1e-6)


def _gain(V: np.ndarray, F: np.ndarray) -> float:
    """Slope of F over V by least squares [N/V]."""
    return float(np.polyfit(V, F, 1)[0])


def public(result: dict) -> dict:
    """The JSON part of a result (no configuration, no plotting data)."""
    return {k: v for k, v in result.items() if not k.startswith("_")}


def summary(result: dict) -> str:
    gb, ga = result["gap_before"], result["gap_after"]
    lines = [f"named effect: {result['named_effect'] or 'no missing effect found'}"
             + (f" (runner-up {result['runner_up']})" if result["named_effect"] else "")]
    for r in result["ranking"]:
        lines.append(f"  {r['effect']:<20} dBIC {r['delta_bic']:>10.1f}  fitted {json.dumps(r['fitted'])}")
    lines.append(f"structure FRF gap [dB]: {gb['structure_frf_db']:.3f} -> {ga['structure_frf_db']:.3f}")
    if gb["actuator_nrmse"] is not None:
        lines.append(f"actuator F_cell NRMSE: {gb['actuator_nrmse']:.4f} -> {ga['actuator_nrmse']:.4f}")
    return "\n".join(lines)

