"""The discrepancy workflow on measured FRFs (docs/discrepancy.md "FRF-file input"): a
folder of FRF files (rt.log.frf_files: FRFs at several F_N1, CSV or UFF with sidecars) and a
nominal model of any structure (--config) instead of a time-series campaign.

The model of an FRF file is the linear one: the plant with the contact stuck at the test's F_N1,
its continuous accelerance at the sensors (plant.linear_frf.point_accelerances), converted to the
file's quantity (rt.log.frf_files.from_accelerance: H_a / (i w)^(2 - k), mobility k = 1,
receptance k = 0). Sensors: a_tip_meas, a_frf_meas are the model's tip and plant.frf_point (their
sidecar positions must match within ``POSITION_TOL_M``); any other name sits at its sidecar
position on the beam that holds it (sidecar sensor_beams where beams overlap), at the model's
point there within ``POSITION_TOL_M``, or at a massless point added to the model there
(``with_sensor_points``: a mesh node, as every point is). It has no friction limit, so mu
cannot act: calibration is E, k_t and the modal damping (rt.discrepancy.diagnose.structure.CAL_FAR:
bounds, priors, k_t and the damping on a log scale), alone or with each implemented structural
candidate of rt.discrepancy.effects.

Data, per test and sensor s: ln|H_s| on the lines where it is above the noise; the noise of
ln|H| per line from the measurement itself: d_k = H_k - (H_{k-1} + H_{k+1}) / 2 (noise variance
x 1.5 where the FRF is smooth over two lines), its local level the running median of |d_k|^2 over
``NOISE_LINES`` lines / ln 2 (robust to the resonances the lines under-resolve), so that

    sigma_k^2 = median|d|^2 / (3 ln 2 |H_k|^2) + FLOOR^2,

lines with sigma_k > MAX_SIGMA (noise-filled antiresonances) left out (FLOOR, MAX_SIGMA as the
impulse workflow's, rt.discrepancy.diagnose.structure).

Drive voltage (sidecar excitation drive_voltage: H per volt, no force measured): H_V = s H_F with
one unknown force scale s [N/V] for the folder's voltage tests. ln s enters every residual of
those tests as the same constant, so it is profiled out in closed form for every model (variable
projection, exact): ln s = sum_k (ln|H_meas| - ln|H_model|)_k / sigma_k^2 / sum_k 1 / sigma_k^2,
kept within ``FORCE_SCALE_N_PER_V``. It is one fitted parameter in the BIC. What it leaves
unidentifiable: the absolute mass and stiffness scale together (every mass and stiffness by one
factor c: rho and E of the beams, the lumped masses, the contact and bolt stiffnesses; the
frequencies stay and |H| scales like 1 / c, as a force scale would); E alone is not (it moves
the frequencies), so E is fitted as with a force, relative to the nominal density, and s absorbs
an error in the nominal mass scale (measured: a nominal with rho and E of the beams x 1.2 fits
s = 1.2008 x the truth, E as before, k_t x 1.2, and names moving_mass 0.004 kg for the screws'
masses that did not scale). The constant s is the current-drive limit of the shaker's two-port; on
drive-voltage tests the shaker in voltage mode is a candidate too (``fit_shaker_frf``: the model's
H times plant.shaker.force_ratio on the model's driving point, the armature mass and the back-EMF
damping c_e = Bl^2 / R fitted, the coil's R and L, flexure and stinger the nominal's ``shaker``).

Stage 1: the measured modes of each test paired with the stuck model's (rt.discrepancy.diagnose.frf_modes:
peaks of all sensors, by shape with >= 3 sensors, else by order: no window around the nominal
frequencies); E, ln k_t (over its decades k_t moves the frequencies by tens of percent) and the
candidate fitted to them (rt.discrepancy.diagnose.structure.fit_frequencies). Stage 2: weighted
log-magnitude residuals r = (ln|H_meas| - ln|H_model|) / sigma_k of all sensors and tests plus
the calibration priors, by rt.discrepancy.diagnose.structure's Gauss-Newton with Broyden updates
on (E, ln k_t, ln modal_damping, the candidate), at most ``MAX_STEPS_FAR`` steps, from the better
of stage 1 and the calibration with the candidate at nominal. Ranking, naming conditions and
result keys as rt.discrepancy.diagnose.campaign (rank, ranking_result); the gap per test [dB] is the RMS of
20 log10|H_meas / H_model| of a_frf_meas (else the first sensor) over rt.discrepancy.diagnose.campaign.
BAND_HZ ("frf_db", the two-accelerometer gap) and over every sensor and the file's whole band
("frf_db_all", "band_hz"). A fitted parameter within ``BOUND_REL`` of a bound is a warning
(``bound_warnings``).

Length: the FRF-file workflow in its reading order (data, model, fit, gap, warnings, the workflow), each
part used by the next; the plausible ranges and their penalty are rt.discrepancy.diagnose.plausible's.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import NamedTuple

import numpy as np
from scipy.ndimage import median_filter
from threadpoolctl import threadpool_limits

from frictionrt.plant.linear_frf import point_accelerances
from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from frictionrt.plant.shaker import force_ratio
from frictionrt.rt.common.config import Config, with_sets
from frictionrt.rt.discrepancy.chain import quiet
from frictionrt.rt.discrepancy.diagnose.campaign import BAND_HZ, bic, feat_gap, modes_table, rank, ranking_result
from frictionrt.rt.discrepancy.diagnose.gauss_newton import gauss_newton_broyden, jacobian_column
from frictionrt.rt.discrepancy.diagnose.structure import (
    CAL_FAR,
    FLOOR,
    LOG_SCALE,
    MAX_SIGMA,
    MODES,
    bounds,
    fd_steps,
    fit_frequencies,
    log_flags,
    from_z,
    prior,
    struct_cfg,
    to_z,
)
from frictionrt.rt.discrepancy.effects import (EFFECTS, MODEL_FORMS, Effect, effect_names, effects_of, get, implemented,
                                               model_forms)
from frictionrt.rt.discrepancy.diagnose.localise import localise as localise_modes
from frictionrt.rt.discrepancy.diagnose.plausible import CLAMP, outside, penalty, ranges, step_box, verdict
from frictionrt.rt.discrepancy.diagnose.frf_modes import MAC_SENSORS, measured_modes, model_modes, pair
from frictionrt.rt.discrepancy.diagnose.watch import done_fit, keeping, rounded, watch
from frictionrt.rt.discrepancy.rig.frf import add_points, sensor_points
from frictionrt.rt.log.frf_files import FRFTest, frf_files, from_accelerance, load_frf_folder

NOISE_LINES = 31                 # running-median window of the noise estimate [lines]
POSITION_TOL_M = 1e-3            # sidecar positions must match the model's points within this [m]
CAL_NAMES = ("E", "k_t", "modal_damping")
MAX_STEPS_FAR = 30               # stage-2 steps at most (a start a decade off needs more than MAX_STEPS)
FORCE_SCALE = "force_scale_N_per_V"          # the drive-voltage tests' force scale, a fitted parameter
FORCE_SCALE_N_PER_V = (1e-3, 1e3)            # its bounds [N/V]: a shaker amplifier's 0.1-100 N/V, widely
SHAKER = "shaker_interaction"                # the shaker's candidate: its armature mass [kg] under this name
BACK_EMF = "back_emf_damping_Ns_per_m"       # and its back-EMF damping c_e = Bl^2 / R [N s/m]
SHAKER_BOUNDS = {SHAKER: (1e-3, 1.0), BACK_EMF: (0.0, 2000.0)}   # their fit's bounds (armature mass > 0: a shaker)
SHAKER_STEPS = {SHAKER: 0.005, BACK_EMF: 3.0}                    # their finite-difference steps
DRIVE_POINT = "_shaker_drive"                # the model's output at the excitation point, for the two-port
BOUND_REL = 0.005                # a parameter within this of a bound (relative; on ln for log-scale ones) is a warning
LEVEL_DB = 1.0                   # a final fit whose FRFs all lie this far above or below the data [dB] is a warning


class FRFData(NamedTuple):
    name: str
    F_N1: float
    freq: np.ndarray             # all lines [Hz]
    H: dict                      # sensor -> measured H on all lines (the file's quantity and excitation)
    sel: dict                    # sensor -> bool mask of the fitted lines
    ln_h: dict                   # sensor -> ln|H_meas| on sel
    sigma: dict                  # sensor -> sigma_k on sel
    f_modes: dict                # {"measured": f [Hz] paired with the model's MODES (NaN: unpaired)}
    stuck: bool = True           # fit_frequencies uses stuck tests: all are (linear measurements)
    quantity: str = "accelerance"
    per_volt: bool = False       # excitation drive_voltage: H per volt, times the unknown force scale
    points: dict | None = None   # sensor -> model point (prepare sets it)
    mac: np.ndarray | None = None      # MAC per model mode (NaN: not paired by shape)
    unpaired_hz: tuple = ()      # measured modes not paired with a model mode [Hz]
    unit: str = "(m/s^2)/N"
    zeta_modes: np.ndarray | None = None   # identified damping ratio per model mode paired (NaN: unpaired)

    @property
    def modes_hz(self) -> np.ndarray:
        """Every measured mode [Hz], paired with the model's or not, ascending."""
        return np.array(sorted({*self.f_modes["measured"][np.isfinite(self.f_modes["measured"])], *self.unpaired_hz}))


def is_frf_folder(folder: str | Path) -> bool:
    """A folder of FRF files: FRF data files (rt.log.frf_files) and no *.mcap measurement."""
    folder = Path(folder)
    return folder.is_dir() and not any(folder.glob("*.mcap")) and bool(frf_files(folder))


def undamped_frequencies(model, F_N1: float) -> np.ndarray:
    """The stuck plant's first len(MODES) natural frequencies at F_N1 [N] (continuous) [Hz]."""
    return stuck_frequencies_hz(model, preloaded_pairs(model, F_N1))[:len(MODES)]


def check_positions(test: FRFTest, cfg: Config) -> None:
    """The sidecar's excitation and measurement-format accelerometer positions are the model's
    points; ValueError otherwise."""
    pts = {p.name: p.x_m for p in cfg.plant.points}
    want = {"excitation": (test.meta["excitation_x_m"], pts[cfg.plant.excitation_point],
                           cfg.plant.excitation_point)}
    want |= {s: (test.meta["sensor_positions_m"][s], pts[p], p) for s, p in sensor_points(cfg).items() if s in test.H}
    for what, (x_file, x_model, point) in want.items():
        if abs(x_file - x_model) > POSITION_TOL_M:
            raise ValueError(f"{test.name}: {what} at x = {x_file:g} m, but the model's point {point!r} is at "
                             f"{x_model:g} m; give the structure of the test with --config, or correct the sidecar")


def _beam_at(cfg: Config, test: FRFTest, s: str, x: float) -> str:
    """The beam of sensor s at x [m] (sidecar sensor_beams, else the one beam that holds x)."""
    spans = {b.name: (b.x0_m, b.x0_m + b.length_m) for b in cfg.plant.beams}
    listing = ", ".join(f"{n} [{a:g}, {b:g}] m" for n, (a, b) in spans.items())
    beam = test.meta.get("sensor_beams", {}).get(s)
    if beam is not None:
        if beam not in spans:
            raise ValueError(f"{test.name}: sensor_beams.{s} = {beam!r}: the model has no such beam (beams: {listing})")
        a, b = spans[beam]
        if not a - POSITION_TOL_M <= x <= b + POSITION_TOL_M:
            raise ValueError(f"{test.name}: sensor {s} at x = {x:g} m is not on beam {beam!r} ({listing}); "
                             "correct sensor_positions_m or sensor_beams, or give the structure with --config")
        return beam
    on = [n for n, (a, b) in spans.items() if a - POSITION_TOL_M <= x <= b + POSITION_TOL_M]
    if not on:
        raise ValueError(f"{test.name}: sensor {s} at x = {x:g} m: no beam of the model holds that x ({listing}); "
                         "correct sensor_positions_m or give the structure of the test with --config")
    if len(on) > 1:
        raise ValueError(f"{test.name}: sensor {s} at x = {x:g} m lies on beams {', '.join(on)}; say which in the "
                         f"sidecar: \"sensor_beams\": {{\"{s}\": \"{on[0]}\"}}")
    return on[0]


def with_sensor_points(tests: list[FRFTest], cfg: Config) -> tuple[Config, dict]:
    """(``cfg`` with a massless point for every sensor of another name than a_tip_meas, a_frf_meas
    that no point of the model within POSITION_TOL_M on its beam holds, {sensor: model point});
    ValueError naming the test where a sensor has no beam, or two positions in the folder."""
    fixed = sensor_points(cfg)
    where, points, added = {}, {}, {}
    for t in tests:
        for s in t.H:
            x = float(t.meta["sensor_positions_m"][s])
            if s in fixed:
                points[s] = fixed[s]
                continue
            beam = _beam_at(cfg, t, s, x)
            if s in where:
                if where[s][1] != beam or abs(where[s][2] - x) > POSITION_TOL_M:
                    raise ValueError(f"{t.name}: sensor {s} at x = {x:g} m on {beam}, but at {where[s][2]:g} m on "
                                     f"{where[s][1]} in {where[s][0]}; give sensors at other places other names")
                continue
            where[s] = (t.name, beam, x)
            known = [(p.name, p.beam, p.x_m) for p in cfg.plant.points] + [(n, b, xa) for n, (b, xa) in added.items()]
            near = [(abs(xp - x), n) for n, b, xp in known if b == beam and abs(xp - x) <= POSITION_TOL_M]
            if near:
                points[s] = min(near)[1]
                continue
            name = s if s not in {n for n, _, _ in known} else f"{s}_sensor"
            added[name] = (beam, x)
            points[s] = name
    return add_points(cfg, added), points


def noise_sigma(H: np.ndarray) -> np.ndarray:
    """sigma_k of ln|H| per line (module docstring)."""
    d = np.empty(len(H))
    d[1:-1] = np.abs(H[1:-1] - 0.5 * (H[:-2] + H[2:])) ** 2
    d[0], d[-1] = d[1], d[-2]
    level = median_filter(d, size=NOISE_LINES, mode="nearest") / math.log(2.0)
    return np.sqrt(level / (3.0 * np.abs(H) ** 2) + FLOOR ** 2)


def prepare(tests: list[FRFTest], nominal: Config) -> list[FRFData]:
    """The fitted lines, ln|H|, sigma and paired mode frequencies of every test, against ``nominal``
    with the sensors' points added (``with_sensor_points``: the models that ``residuals`` gets
    must hold them too)."""
    for t in tests:
        check_positions(t, nominal)
    nominal, points = with_sensor_points(tests, nominal)
    m0 = build_plant(quiet(nominal))
    out = []
    for t in tests:
        sel, ln_h, sig, full = {}, {}, {}, {}
        for s in t.H:
            sk = noise_sigma(t.H[s])
            full[s] = sk
            sel[s] = sk < MAX_SIGMA
            ln_h[s] = np.log(np.abs(t.H[s][sel[s]]))
            sig[s] = sk[sel[s]]
        meas = measured_modes(t.freq_hz, t.H, full)
        mod = model_modes(m0, t.F_N1, [points[s] for s in t.H], len(MODES))
        f_paired, mac = pair(meas, mod)
        unpaired = tuple(round(float(f), 3) for f in meas.f_hz if not np.any(f_paired == f))
        zeta = np.array([meas.zeta[np.flatnonzero(meas.f_hz == f)[0]] if np.isfinite(f) else math.nan
                         for f in f_paired])
        out.append(FRFData(t.name, t.F_N1, t.freq_hz, t.H, sel, ln_h, sig, {"measured": f_paired}, True,
                           t.quantity, t.excitation == "drive_voltage", {s: points[s] for s in t.H}, mac, unpaired,
                           t.unit, zeta))
    return out


def model_H(cfg: Config, data: list[FRFData], shaker: Config | None = None) -> list[dict]:
    """The model's FRFs {sensor: H} on every test's lines at its F_N1, in the test's quantity per
    newton (``cfg`` holds the sensors' points); with ``shaker`` (a configuration whose shaker is on) the
    drive-voltage tests' per newton of drive: times F_exc / drive of its two-port
    (plant.shaker.force_ratio) on the model's driving point at the excitation point."""
    model = build_plant(quiet(cfg))
    out = []
    for d in data:
        two_port = shaker is not None and d.per_volt
        pts = d.points | ({DRIVE_POINT: cfg.plant.excitation_point} if two_port else {})
        Ha = point_accelerances(model, pts, d.F_N1, d.freq)
        ratio = 1.0
        if two_port:
            ratio = force_ratio(shaker, d.freq, -Ha.pop(DRIVE_POINT) / (2 * np.pi * d.freq) ** 2)
        out.append({s: from_accelerance(h * ratio, d.freq, d.quantity) for s, h in Ha.items()})
    return out


def residuals(cfg: Config, data: list[FRFData]) -> tuple[dict, list[dict], float | None]:
    """({"FRF <sensor>": weighted log-magnitude residuals over all tests}, model H per test (the
    drive-voltage tests' times the force scale), the force scale [N/V] profiled out (module
    docstring) or None without drive-voltage tests)."""
    return weighted_residuals(data, model_H(cfg, data))


NO_SOLUTION = 30.0   # weighted residual of a line where the model has no value (a harmonic balance without solution)


def weighted_residuals(data: list[FRFData], Hm: list[dict], profile_scale: bool = True
                       ) -> tuple[dict, list[dict], float | None]:
    """``residuals`` of the model FRFs ``Hm`` {sensor: H per newton} per test (any model: the stuck
    linear one, rt.discrepancy.diagnose.levels' harmonic balance). A line where the model is not finite
    gets the residual ``NO_SOLUTION`` and stays out of the force scale. ``profile_scale`` False: the
    drive-voltage tests' ``Hm`` are per volt already (a nonlinear model, whose force the scale sets)."""
    raw = [{s: (d.ln_h[s] - np.log(np.maximum(np.abs(h[s][d.sel[s]]), 1e-300))) for s in d.sel}
           for d, h in zip(data, Hm)]
    scale = None
    if profile_scale and any(d.per_volt for d in data):
        ok = [{s: np.isfinite(r[s]) for s in r} for r in raw]
        num = sum(float(np.sum(r[s][k[s]] / d.sigma[s][k[s]] ** 2))
                  for d, r, k in zip(data, raw, ok) if d.per_volt for s in r)
        den = sum(float(np.sum(1.0 / d.sigma[s][k[s]] ** 2)) for d, r, k in zip(data, raw, ok) if d.per_volt for s in r)
        ln_s = min(max(num / den, math.log(FORCE_SCALE_N_PER_V[0])), math.log(FORCE_SCALE_N_PER_V[1]))
        scale = math.exp(ln_s)
        for d, r, h in zip(data, raw, Hm):
            if d.per_volt:
                for s in r:
                    r[s] = r[s] - ln_s
                    h[s] = h[s] * scale
    out = {}
    for d, r in zip(data, raw):
        for s in r:
            out.setdefault(f"FRF {s}", []).append(np.where(np.isfinite(r[s]), r[s] / d.sigma[s], NO_SOLUTION))
    return {k: np.concatenate(v) for k, v in out.items()}, Hm, scale


class Fit(NamedTuple):
    theta: dict
    channels: dict       # "FRF <sensor>" -> weighted residuals
    H: list              # model {sensor: H} per test
    cfg: Config
    J: dict              # parameter -> Jacobian column at theta (reused by the candidates)


def _theta(names, x, scale) -> dict:
    return dict(zip(names, map(float, x))) | ({FORCE_SCALE: scale} if scale is not None else {})


def fit_label(effect) -> str:
    """The name of a fit of the calibration (with ``effect``: one or a tuple) in the report and its progress bar."""
    return " + ".join(effect_names(effect)) or "calibration only"


def fit(nominal: Config, data: list[FRFData], effect: Effect | None, calibrated: Fit | None = None,
        plausible: dict | None = None, bars: bool = False, label: str | None = None) -> Fit:
    """Stage 1 then stage 2 (module docstring) of the calibration alone (effect None) or with the
    effect; with ``calibrated`` stage 2 starts from the better of stage 1 and the calibration with
    the effect at its nominal strength, there with the calibration's Jacobian columns (so a
    candidate never fits worse than calibration alone). Stage 2 is rt.discrepancy.diagnose.structure's
    Gauss-Newton with Broyden updates (a finite-difference Jacobian only at the start and when a
    step fails) on z: ln(scale) for the LOG_SCALE parameters, the scale itself for the others. Both
    penalised outside the ``plausible`` ranges (default: plausible.ranges; {}: let go; plausible.penalty).
    ``bars``: stage 2's model evaluations on a tqdm bar on stderr named ``label`` (default ``fit_label``); Ctrl-C
    in stage 2 raises FitInterrupted with its best point (rt.discrepancy.diagnose.watch)."""
    names = list(CAL_NAMES) + effect_names(effect)
    nominal_of = {e.name: e.nominal for e in effects_of(effect)}
    log = log_flags(names, effect)
    lo, hi = (to_z(b, log) for b in bounds(names, effect, nominal))
    steps = fd_steps(names, effect)
    plausible = ranges(nominal, names) if plausible is None else plausible
    n = sum(len(v) for d in data for v in d.ln_h.values())

    def pen(names_, x, n_=n):                    # n_: stage 1 has its own number of residuals
        return penalty(names_, x, plausible, n_)

    def evaluate(z):
        x = from_z(z, log)
        ch, H, scale = residuals(struct_cfg(nominal, dict(zip(names, x)), effect), data)
        r = np.concatenate([*ch.values(), prior(names, x), pen(names, x)])
        ev.seen(z, r)
        return (ch, H, scale), r

    def point(z):
        theta = dict(zip(names, map(float, from_z(z, log))))
        return theta, struct_cfg(nominal, theta, effect)

    stage1 = fit_frequencies(nominal, data, effect, frequencies=undamped_frequencies, penalty=pen)
    with watch(label or fit_label(effect), bars, point) as ev:
        z = np.clip(to_z(np.array([stage1.get(k, 1.0) for k in names]), log), lo, hi)
        run, r = evaluate(z)
        J = None
        if calibrated is not None and effect is not None:
            z_cal = to_z(np.array([calibrated.theta.get(k, nominal_of.get(k)) for k in names]), log)
            x_cal = from_z(z_cal, log)
            r_cal = np.concatenate([*calibrated.channels.values(), prior(names, x_cal), pen(names, x_cal)])
            if r_cal @ r_cal < r @ r:
                z, run, r = z_cal, (calibrated.channels, calibrated.H, calibrated.theta.get(FORCE_SCALE)), r_cal
                # the calibration's columns gain the effect's penalty row, which they do not move (one effect
                # on the calibration alone; otherwise finite differences)
                if len(nominal_of) == 1 and all(len(calibrated.J.get(k, ())) == len(r) - 1 for k in names[:-1]):
                    J = np.column_stack([np.append(calibrated.J[k], 0.0) for k in names[:-1]]
                                        + [jacobian_column(evaluate, z, r, len(names) - 1, steps, hi)])
        z, (ch, H, scale), r, J = gauss_newton_broyden(evaluate, z, run, r, J, lo, hi, steps, MAX_STEPS_FAR,
                                                       lambda z: step_box(names, z, log, plausible, lo, hi))
        theta = _theta(names, from_z(z, log), scale)
        return Fit(theta, ch, H, struct_cfg(nominal, theta, effect), dict(zip(names, J.T)))


def shaker_mode(nominal: Config) -> str:
    """The amplifier's mode of the shaker candidate: the nominal's ``shaker.amplifier`` where the nominal
    describes a shaker (armature mass > 0), else "voltage" (FRFs per drive volt without a force)."""
    return nominal.shaker.amplifier if nominal.shaker.on else "voltage"


def shaker_config(cfg: Config, mass_kg: float, back_emf_Ns_per_m: float | None, mode: str = "voltage") -> Config:
    """``cfg`` with its shaker in amplifier ``mode``, armature mass ``mass_kg`` [kg] and, in voltage mode,
    back-EMF damping c_e = Bl^2 / R [N s/m] at ``cfg``'s coil resistance R (the lab's ohmmeter) and
    inductance: Bl = sqrt(c_e R) (not validated: a fit's trial point). In current mode Bl stays ``cfg``'s
    (the force per drive does not depend on it)."""
    s = cfg.shaker
    Bl = (s.force_constant_N_per_A if mode == "current" else
          max(math.sqrt(max(back_emf_Ns_per_m, 0.0) * s.coil_resistance_ohm), 1e-9))
    return dataclasses.replace(cfg, shaker=dataclasses.replace(
        s, amplifier=mode, armature_mass_kg=float(mass_kg), force_constant_N_per_A=Bl))


def fit_shaker_frf(nominal: Config, data: list[FRFData], calibrated: Fit, bars: bool = False) -> Fit:
    """The shaker's candidate on FRF files per drive volt (docs/discrepancy.md "The shaker on FRFs per
    drive volt"): the model's H per newton times the force per drive of a voltage-driven shaker
    (plant.shaker.force_ratio, ``shaker_config``) and the profiled force scale, fitted on E, ln k_t,
    ln modal_damping, the armature mass (theta[SHAKER], kg) and c_e (theta[BACK_EMF], N s/m) by stage 2's
    Gauss-Newton with Broyden updates, from the calibration with the shaker at the nominal's catalogue
    values (its armature mass, else the effect's default strength; its Bl^2 / R). Known (the nominal's
    ``shaker``): coil resistance and inductance, flexure, stinger. Penalised as ``fit`` outside the
    plausible ranges of the calibration scales. A nominal whose shaker is on in current mode
    (``shaker_mode``): the current-driven shaker, its armature mass alone fitted (no back-EMF term)."""
    mode = shaker_mode(nominal)
    names = [*CAL_NAMES, SHAKER] + ([BACK_EMF] if mode == "voltage" else [])
    log = np.array([k in LOG_SCALE for k in names])
    c_lo, c_hi = bounds(list(CAL_NAMES), None, nominal)
    lo = to_z(np.r_[c_lo, [SHAKER_BOUNDS[k][0] for k in names[3:]]], log)
    hi = to_z(np.r_[c_hi, [SHAKER_BOUNDS[k][1] for k in names[3:]]], log)
    steps = np.r_[fd_steps(list(CAL_NAMES), None), [SHAKER_STEPS[k] for k in names[3:]]]
    plausible = ranges(nominal, names)
    n = sum(len(v) for d in data for v in d.ln_h.values())
    sh = nominal.shaker
    c_e0 = sh.force_constant_N_per_A ** 2 / sh.coil_resistance_ohm

    def point(z):
        theta = dict(zip(names, map(float, from_z(z, log))))
        cfg = struct_cfg(nominal, theta, None)
        return theta, shaker_config(cfg, theta[SHAKER], theta.get(BACK_EMF), mode)

    def evaluate(z):
        x = from_z(z, log)
        theta, shaker = point(z)
        ch, H, scale = weighted_residuals(data, model_H(struct_cfg(nominal, theta, None), data, shaker))
        r = np.concatenate([*ch.values(), prior(names, x), penalty(names, x, plausible, n)])
        ev.seen(z, r)
        return (ch, H, scale), r

    with watch(SHAKER, bars, point) as ev:
        start = [calibrated.theta[k] for k in CAL_NAMES] + [sh.armature_mass_kg if sh.on else
                                                            EFFECTS[SHAKER].parameter.default, c_e0][:len(names) - 3]
        z = np.clip(to_z(np.array(start), log), lo, hi)
        run, r = evaluate(z)
        z, (ch, H, scale), r, J = gauss_newton_broyden(evaluate, z, run, r, None, lo, hi, steps, MAX_STEPS_FAR,
                                                       lambda z: step_box(names, z, log, plausible, lo, hi))
        theta, shaker = point(z)
        final = with_sets(shaker, [f"shaker.force_constant_N_per_A={shaker.shaker.force_constant_N_per_A!r}"])
        return Fit(_theta(names, from_z(z, log), scale), ch, H, final, dict(zip(names, J.T)))


def _rms_db(H: np.ndarray, Hm: np.ndarray) -> float:
    return float(np.sqrt(np.mean((20 * np.log10(np.abs(H) / np.abs(Hm))) ** 2)))


def gap_db(data: list[FRFData], Hm: list[dict]) -> dict:
    """Per test: "frf_db", the RMS of 20 log10|H_meas / H_model| of a_frf_meas (else the first
    sensor) over BAND_HZ (the whole band where the file does not reach into it) [dB], the
    two-accelerometer gap; "frf_db_all", the same over every sensor and all lines; "band_hz" the file's band.
    Their means over the tests ("structure_frf_db", "structure_frf_db_all"); "actuator_nrmse" None
    (no actuator test)."""
    out = {}
    for d, h in zip(data, Hm):
        s = "a_frf_meas" if "a_frf_meas" in d.sel else next(iter(d.sel))
        band = (d.freq >= BAND_HZ[0]) & (d.freq <= BAND_HZ[1])
        band = band if band.any() else np.ones(len(d.freq), bool)
        every = np.concatenate([20 * np.log10(np.abs(d.H[k]) / np.abs(h[k])) for k in d.sel])
        out[d.name] = {"frf_db": round(_rms_db(d.H[s][band], h[s][band]), 4),
                       "frf_db_all": round(float(np.sqrt(np.mean(every ** 2))), 4),
                       "band_hz": [float(d.freq[0]), float(d.freq[-1])]}
    out["structure_frf_db"] = round(float(np.mean([out[d.name]["frf_db"] for d in data])), 4)
    out["structure_frf_db_all"] = round(float(np.mean([out[d.name]["frf_db_all"] for d in data])), 4)
    out["actuator_nrmse"] = None
    return out


FIXES = {
    "E": "widen CAL_FAR's E range only if a factor 2 in E is plausible; check the nominal E and density of the "
         "beams (plant.beams.*.E, rho) and the structure's dimensions",
    "k_t": "check the nominal plant.interface.k_t_area (more than a factor 100 off?) and whether the joint is stuck at "
           "the test's level and where the model puts it",
    "modal_damping": "check the nominal plant.modal_damping; at the upper bound the data have more damping than a "
                     "stuck linear model gives (slip, an effect not in the library)",
    FORCE_SCALE: "check the sidecar's quantity and the FRF's units (V or mV, g or m/s^2, m or mm)",
}
NO_FORCE_HINT = "; or the data have no force: if the FRF is per drive voltage, set the sidecar's excitation to drive_voltage"


def bound_warnings(theta: dict, effect: Effect | None, per_volt: bool, nominal: Config,
                   log_bounds: dict | None = None) -> list[dict]:
    """{"parameter", "value", "bound", "fix"} for every fitted parameter within BOUND_REL of a bound of its
    fit (rt.discrepancy.diagnose.structure.bounds around ``nominal``; ``log_bounds`` {name: (lo, hi)} for the
    fits with their own) (relative to the bound; on ln for the LOG_SCALE ones, the force scale and those of
    ``log_bounds``; relative to the range for a bound 0)."""
    out = []
    for k, v in theta.items():
        if k == FORCE_SCALE:
            lo, hi, log = *FORCE_SCALE_N_PER_V, True
        elif k in SHAKER_BOUNDS and effect is None:
            lo, hi, log = *SHAKER_BOUNDS[k], False
        elif log_bounds and k in log_bounds:
            lo, hi, log = *log_bounds[k], True
        else:
            (lo,), (hi,) = bounds([k], effect, nominal)
            log = k in LOG_SCALE or (effect is not None and k == effect.name and effect.log_scale)
        for b in (lo, hi):
            near = (abs(math.log(v / b)) <= math.log1p(BOUND_REL) if log
                    else abs(v - b) <= BOUND_REL * (abs(b) if b != 0 else hi - lo))
            if near:
                fix = FIXES.get(k, f"widen the range of {k} ({lo:g}..{hi:g}) or check where the model puts the effect")
                if k in CAL_FAR and not per_volt:
                    fix += NO_FORCE_HINT
                out.append({"parameter": k, "value": float(f"{v:.6g}"), "bound": float(b), "fix": fix})
    return out


def level_offset_db(data: list[FRFData], Hm: list[dict]) -> float:
    """The weighted mean of 20 log10|H_meas / H_model| over the fitted lines of every sensor and
    test (weights 1 / sigma_k^2) [dB]: a level no calibration parameter can move (a force or unit
    error) shows here."""
    num = den = 0.0
    for d, h in zip(data, Hm):
        for s in d.sel:
            w = 1.0 / d.sigma[s] ** 2
            num += float(np.sum(w * 20 * np.log10(np.abs(d.H[s][d.sel[s]]) / np.abs(h[s][d.sel[s]]))))
            den += float(np.sum(w))
    return num / den


def level_warning(offset_db: float, per_volt: bool) -> list[dict]:
    """A warning (bound None) if the final model's FRFs lie LEVEL_DB or more off the data throughout."""
    if abs(offset_db) < LEVEL_DB or per_volt:
        return []
    return [{"parameter": "level_offset_db", "value": round(offset_db, 3), "bound": None,
             "fix": "the measured FRFs lie this far from the calibrated model at every line: check the units "
                    "(g or m/s^2, mm or m, mV or V) and the quantity" + NO_FORCE_HINT}]


def diagnose_frf(folder: str | Path, nominal: Config | None = None, progress=None, bars: bool = False) -> dict:
    """The workflow (module docstring) on a folder of FRF files; the result dict as rt.discrepancy.diagnose.campaign's,
    with the fitted configuration under "_config" and the plotting data under "_plots". ``progress(msg)``: the
    stages; ``bars``: tqdm bars on stderr inside the fits. Ctrl-C raises Interrupted with the fits done so far
    (rt.discrepancy.diagnose.watch)."""
    with threadpool_limits(1):
        return _diagnose_frf(folder, nominal, progress or (lambda msg: None), bars)


def _candidates(nominal: Config) -> tuple[list[Effect], dict[str, str]]:
    """The implemented effects linear FRFs can show (``Effect.visible_in_frf_files``: structural, and
    changing the stuck structure) that the structure has a place for (a clamp, an adaptive screw,
    the accelerometer points), then the model-form candidates (``MODEL_FORMS``): those that apply to
    ``nominal`` at their default strength; and {name: why not} for every other one."""
    out, why = [], {}
    for e in [*EFFECTS.values(), *model_forms()]:
        if not e.implemented:
            why[e.name] = "not implemented yet"
            continue
        if e.name == SHAKER:
            why[e.name] = ("the force is measured at the structure (FRFs per newton): no shaker model is needed; "
                           "FRF files per drive volt (sidecar excitation drive_voltage) try it")
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


def next_candidate(nominal: Config, data: list[FRFData], held: Effect, held_fit: Fit, candidates: list[Effect],
                   say, bars: bool, done: dict, pointed: Effect | None = None) -> dict:
    """Forward selection after a candidate is named: each other candidate fitted together with the named
    one (``fit`` of the pair: the calibration and both strengths free, from the better of their frequency
    fit and the named one's fit with the other at nominal), and, where the localisation points at another
    candidate (``pointed``), each candidate together with that one; all ranked against the named one's fit
    by the same rules (rt.discrepancy.diagnose.campaign.rank: BIC with one parameter more, its share of the
    FRF residuals, its strength off nominal). {"named": the pair's second or None, "held": the pair's first,
    "ranking": its rows, "held_strength": the named one's strength fitted alone, "final": the pair's result
    {"effect", "theta" (both strengths), "fit", "cfg", "channels"} or None}."""
    results = [{"effect": None, "theta": held_fit.theta, "channels": held_fit.channels,
                "score": bic(held_fit.channels, len(held_fit.theta)), "fit": held_fit}]
    pairs = [(held, e) for e in candidates]
    if pointed is not None and pointed.name != held.name:
        pairs += [(pointed, e) for e in [held, *candidates] if e.name != pointed.name]
    for first, e in pairs:
        label = fit_label((first, e))
        say(f"fit {label}")
        f = fit(nominal, data, (first, e), calibrated=held_fit if first is held else None, bars=bars, label=label)
        done[label] = done_fit(f.theta, f.cfg)
        results.append({"effect": e.name, "held": first.name, "theta": f.theta, "channels": f.channels,
                        "score": bic(f.channels, len(f.theta)), "fit": f, "cfg": f.cfg})
    base2, ranked2, winner2 = rank(results)
    rows = [{"effect": r["effect"], "with": r["held"], "score": round(r["score"], 2),
             "delta_bic": round(base2["score"] - r["score"], 2), "rss_reduction": round(r["rss_reduction"], 4),
             "gap_after": feat_gap(r), "fitted": {k: float(f"{v:.5g}") for k, v in r["theta"].items()}}
            for r in ranked2]
    final = None if winner2 is None else winner2 | {"effect": winner2["held"]}
    return {"named": winner2["effect"] if winner2 else None, "held": winner2["held"] if winner2 else held.name,
            "ranking": rows, "held_strength": float(f"{held_fit.theta[held.name]:.6g}"), "final": final}


def _diagnose_frf(folder, nominal: Config | None, say, bars: bool) -> dict:
    nominal = nominal if nominal is not None else with_sets(Config(), [])
    tests = load_frf_folder(folder)                          # bad input raises before any progress line
    try:
        data = prepare(tests, nominal)
        nominal, _ = with_sensor_points(tests, nominal)
    except ValueError as exc:
        raise ValueError(f"{folder}: {exc}") from None
    if not any(d.sel for d in data):
        raise ValueError(f"{folder}: no FRF line above the noise in any test")
    with keeping({}, input="frf_files") as done:
        return _fit_and_report(nominal, data, say, bars, done)


def _fit_and_report(nominal: Config, data: list[FRFData], say, bars: bool, done: dict) -> dict:
    """The fits, ranking and report of ``_diagnose_frf``; each fit, once done, also into ``done``
    {name: ``done_fit``} (what an interruption keeps)."""
    ch0, H0, scale0 = residuals(nominal, data)
    fits = {}
    candidates, why_not = _candidates(nominal)
    forms = [e for e in candidates if e.name in MODEL_FORMS]
    candidates = [e for e in candidates if e.name not in MODEL_FORMS]
    say(f"fit {fit_label(None)}")
    fits[None] = fit(nominal, data, None, bars=bars)
    done[fit_label(None)] = done_fit(fits[None].theta, fits[None].cfg)
    pressed = outside(fits[None].theta, ranges(nominal, list(CAL_NAMES)))
    mode = nominal.diagnosis.model_form
    if mode == "always" or (mode == "auto" and pressed):
        candidates = [*candidates, *forms]
    else:
        reason = ("diagnosis.model_form = never" if mode == "never" else
                  "the calibration alone keeps every parameter within its plausible range: the model's form is "
                  "not in question (diagnosis.model_form = always tries it)")
        why_not |= {e.name: reason for e in forms}
    say("localisation")
    where = localise_modes(data, nominal, fits[None].cfg, fits[None].H, candidates, len(MODES))
    for eff in candidates:
        say(f"fit {fit_label(eff)}")
        fits[eff] = fit(nominal, data, eff, calibrated=fits[None], bars=bars)
        done[fit_label(eff)] = done_fit(fits[eff].theta, fits[eff].cfg)
    results = [{"effect": e.name if e else None, "theta": f.theta, "channels": f.channels,
                "score": bic(f.channels, len(f.theta)), "fit": f, "cfg": f.cfg} for e, f in fits.items()]
    if any(d.per_volt for d in data):           # the shaker's two-port, on the drive-voltage tests
        say(f"fit {SHAKER} ({shaker_mode(nominal)}-driven shaker)")
        f = fit_shaker_frf(nominal, data, fits[None], bars=bars)
        done[SHAKER] = done_fit(f.theta, f.cfg)
        why_not.pop(SHAKER, None)
        tried = [*candidates, EFFECTS[SHAKER]]
        results.append({"effect": SHAKER, "theta": f.theta, "channels": f.channels, "group": "FRF",
                        "score": bic(f.channels, len(f.theta)), "fit": f, "cfg": f.cfg})
    else:
        tried = candidates
    base, ranked, winner = rank(results)
    second = None
    if winner is not None and winner["effect"] != SHAKER and len(candidates) > 1 and (
            mode == "always" or outside(winner["theta"], ranges(nominal, list(CAL_NAMES)))):
        pointed = next((e for e in candidates if e.name == where["points_at"]), None)
        second = next_candidate(nominal, data, get(winner["effect"]), winner["fit"],
                                [e for e in candidates if e.name != winner["effect"]], say, bars, done, pointed)
    final = second["final"] if second and second["named"] else (winner or base)
    plausible = ranges(nominal, [*CAL_NAMES, CLAMP])
    let_go = None
    if winner is None and outside(base["theta"], plausible):     # no candidate took their place: let them go
        label = "calibration only, the plausible ranges let go"
        say(f"fit {label}")
        free = fit(nominal, data, None, plausible={}, bars=bars, label=label)
        done[label] = done_fit(free.theta, free.cfg)
        let_go = {"fitted": rounded(free.theta), "gap_db": gap_db(data, free.H)["structure_frf_db"]}
    m0 = build_plant(quiet(nominal))
    localise = {}
    for d, h in zip(data, H0):
        table = modes_table(undamped_frequencies(m0, d.F_N1), d.f_modes)
        for j, row in table.items():
            mac = d.mac[int(j) - 1] if d.mac is not None else math.nan
            if math.isfinite(mac):
                row["mac"] = round(float(mac), 3)
        localise[d.name] = {"F_N1_N": round(d.F_N1, 1), "frf_db_nominal": gap_db([d], [h])[d.name]["frf_db"],
                            "frf_db_all_nominal": gap_db([d], [h])[d.name]["frf_db_all"], "modes": table,
                            "paired_by": "shape (MAC)" if len(d.H) >= MAC_SENSORS else "order",
                            "unpaired_measured_hz": list(d.unpaired_hz)}
    gap = {"gap_before": gap_db(data, H0), "gap_calibrated": gap_db(data, base["fit"].H),
           "gap_after": gap_db(data, final["fit"].H)}
    m1 = build_plant(quiet(final["cfg"]))
    modes_after = {d.name: modes_table(undamped_frequencies(m1, d.F_N1), d.f_modes) for d in data}
    out = ranking_result(base, ranked, winner, gap, localise, ch0, modes_after)
    named = [winner["effect"]] if winner else []
    if second is not None:
        named = [second["held"], second["named"]] if second["named"] else named
        out["named_effect"] = named[0]          # the pair replaces a first named one it does not hold
        out["second_round"] = {"first_named": winner["effect"], "held": second["held"],
                               "held_strength": second["held_strength"], "named": second["named"],
                               "ranking": second["ranking"]}
        out["fitted_parameters"] = {k: float(f"{v:.6g}") for k, v in final["theta"].items()}
        out["_config"] = final["cfg"]
    out["named"] = named
    out["model_form"] = {
        "tried": [e.name for e in candidates if e.form],
        "named": [n for n in named if get(n).form],
        "ranking": [r for r in out["ranking"] if get(r["effect"]).form],
        "mode": mode}
    for r in out["ranking"] + (out.get("second_round") or {}).get("ranking", []):
        r["kind"] = "model form" if get(r["effect"]).form else "effect"
    out["where"] = where
    out["not_tried"] += [e.name for e in implemented() + model_forms() if e not in tried]   # not visible, no place
    per_volt = any(d.per_volt for d in data)
    offset = level_offset_db(data, final["fit"].H)
    out["level_offset_db"] = round(offset, 4)
    by_effect = [(e, {k: v for k, v in final["theta"].items() if k not in named or k == e.name})
                 for e in tried if e.name in named and e.name != SHAKER] or [(None, final["theta"])]
    out["warnings"] = [w for k, (e, th) in enumerate(by_effect)
                       for w in bound_warnings(th if k == 0 else {e.name: th[e.name]}, e, per_volt, nominal)
                       ] + level_warning(offset, per_volt)
    out["plausibility"] = verdict(plausible, base["theta"], final["theta"], " and ".join(named) or None,
                                  [e.name for e in tried], let_go)
    out["sensors"] = {s: {"point": p, "quantity": d.quantity, "unit": d.unit} for d in data for s, p in d.points.items()}
    if per_volt:
        out["excitation"] = {
            "kind": "drive_voltage", FORCE_SCALE: float(f"{final['theta'][FORCE_SCALE]:.6g}"),
            "force_scale_nominal_N_per_V": float(f"{scale0:.6g}"),
            "note": "the data have no force: the FRFs are per drive volt; one force scale [N/V] fitted for the "
                    "folder. The absolute mass and stiffness scale (every mass and stiffness by one factor: beam "
                    "density and E, lumped masses, contact and bolt stiffnesses) cannot be separated from it; E "
                    "is fitted from the frequencies relative to the nominal density, and the scale absorbs an "
                    "error in the nominal mass scale"}
    return out | {"input": "frf_files", "not_tried_reasons": why_not,
                  "_plots": {"frf": [(d.name, d.F_N1, d.freq, d.H, h0, h1)
                                     for d, h0, h1 in zip(data, H0, final["fit"].H)], "act": [],
                             "frf_units": {d.name: d.unit for d in data},
                             "frf_quantity": {d.name: d.quantity for d in data}}}
