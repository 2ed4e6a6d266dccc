"""Measured modes of FRF files and their pairing with the model's (docs/discrepancy.md
"FRF-file input"): no window around the nominal frequencies, so that a first model tens of percent
off still pairs every measured mode.

Measured modes, per test: the peaks of ln|H_s| of every sensor s (scipy.signal.find_peaks) with a
prominence of at least ``PEAK_PROMINENCE`` on lines whose noise sigma_k (rt.discrepancy.diagnose.frf.
noise_sigma) is below ``PEAK_SIGMA`` (a noise spike in an antiresonance floor is not a mode);
peaks of different sensors within ``MERGE_REL`` are one mode; its frequency by
plant.impulse.identify (no window) on the sensor with the highest peak, in a band of 0.4 x the
distance to the neighbouring peaks (at most 8 %); a peak that identify cannot fit as a mode, or
only with a damping ratio above ``ZETA_MAX`` (the hump between two close antiresonances), is not a
mode; its shape the complex H_s of every sensor at the mode's line.

Model modes: the stuck model's first len(MODES) eigenmodes at the test's F_N1 (eigenvectors of
plant.model.stuck_stiffness in the plant's modal coordinates, M = I), their shape at the sensors'
points (out_rows u_k) and their visibility max_s |r_s u_k| |b_exc u_k| (the peak of an accelerance
at equal damping); modes below ``VISIBLE_REL`` of the most visible are not expected in the data.

Pairing: with >= ``MAC_SENSORS`` sensors by shape: the assignment (scipy.optimize.
linear_sum_assignment) of measured to visible model modes that maximises the sum of the modal
assurance criterion MAC = |phi_a^T conj(h)|^2 / (|phi_a|^2 |h|^2) (h complex: the common factor of
a resonance cancels), pairs with MAC >= ``MAC_MIN`` kept; otherwise by order: measured mode i with
visible model mode i + o, the offset o the one with the most pairs whose frequency ratio is within
``RATIO_RANGE`` (a model up to a factor 2 in E off), then the least spread of ln(f_meas / f_model)
(a wrong E shifts every mode by the same ratio).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.signal import find_peaks

from frictionrt.plant.impulse import identify
from frictionrt.plant.model import preloaded_pairs, stuck_stiffness

PEAK_PROMINENCE = 1.0            # a mode's peak stands this far above its surroundings [ln |H|] (8.7 dB)
PEAK_SIGMA = 0.1                 # ... on a line with noise sigma_k below this (relative)
MERGE_REL = 0.005                # peaks of two sensors this close (relative) are one mode
VISIBLE_REL = 1e-3               # model modes less visible than this x the most visible are not expected
MAC_SENSORS = 3                  # sensors needed to pair by shape
MAC_MIN = 0.6                    # a shape pair needs at least this MAC
RATIO_RANGE = (0.7, 1.42)        # f_meas / f_model of an order pair (E within a factor 2)
MAX_HALF_BAND = 0.08             # identification band, relative
ZETA_MAX = 0.05                  # a peak identified with more damping than this is not a mode


class Measured(NamedTuple):
    f_hz: np.ndarray                 # (m,) identified frequencies [Hz], increasing
    shapes: np.ndarray               # (m, sensors) complex H_s at each mode's line
    zeta: np.ndarray | None = None   # (m,) identified damping ratios [-]


class ModelModes(NamedTuple):
    f_hz: np.ndarray                 # (len(MODES),) undamped [Hz]
    shapes: np.ndarray               # (len(MODES), sensors) real, at the sensors' points
    visible: np.ndarray              # (len(MODES),) bool


def measured_modes(freq: np.ndarray, H: dict, sigma: dict) -> Measured:
    """The measured modes of one test (module docstring); H, sigma {sensor: (lines,)}."""
    found = []                                            # (f, sensor, height)
    for s, h in H.items():
        y = np.log(np.maximum(np.abs(h), 1e-300))
        idx, prop = find_peaks(y, prominence=PEAK_PROMINENCE)
        for i, prom in zip(idx, prop["prominences"]):
            if sigma[s][i] < PEAK_SIGMA:
                found.append((float(freq[i]), s, float(y[i])))
    found.sort()
    groups: list[list] = []
    for p in found:
        if groups and p[0] <= groups[-1][0][0] * (1.0 + MERGE_REL):
            groups[-1].append(p)
        else:
            groups.append([p])
    f_peak = np.array([max(g, key=lambda p: p[2])[0] for g in groups])
    f_out, z_out, keep = np.empty(len(groups)), np.empty(len(groups)), np.zeros(len(groups), bool)
    for k, g in enumerate(groups):
        s = max(g, key=lambda p: p[2])[1]
        gaps = [abs(f_peak[j] / f_peak[k] - 1.0) for j in (k - 1, k + 1) if 0 <= j < len(groups)]
        half = min([MAX_HALF_BAND] + [0.4 * x for x in gaps])
        f_id, zeta = (v[0] for v in identify(freq, H[s], np.array([f_peak[k]]), math.inf, half))
        f_out[k], z_out[k], keep[k] = f_id, zeta, bool(np.isfinite(f_id) and 0.0 < zeta < ZETA_MAX)
    lines = np.searchsorted(freq, f_peak[keep]).clip(0, len(freq) - 1)
    shapes = np.array([[H[s][i] for s in H] for i in lines], complex).reshape(len(lines), len(H))
    return Measured(f_out[keep], shapes, z_out[keep])


def model_modes(model, F_N1: float, points: list[str], n_modes: int) -> ModelModes:
    """The stuck model's first n_modes modes at F_N1 [N] at the named plant ``points`` (module docstring)."""
    lam, U = np.linalg.eigh(stuck_stiffness(model, preloaded_pairs(model, F_N1)))
    f = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
    keep = np.flatnonzero(f > 1e-3)[:n_modes]
    U = U[:, keep]
    rows = model.params.out_rows[[model.structure.point_names.index(p) for p in points]]
    shapes = (rows @ U).T
    part = np.abs(model.params.b_exc @ U) * np.max(np.abs(shapes), axis=1)
    return ModelModes(f[keep], shapes, part >= VISIBLE_REL * np.max(part))


def mac(phi: np.ndarray, h: np.ndarray) -> float:
    """|phi^T conj(h)|^2 / (|phi|^2 |h|^2) of a real model shape and a complex measured one."""
    den = float(np.vdot(phi, phi).real * np.vdot(h, h).real)
    return float(abs(np.vdot(h, phi)) ** 2 / den) if den > 0 else 0.0


def pair(meas: Measured, mod: ModelModes) -> tuple[np.ndarray, np.ndarray]:
    """(f_meas per model mode [Hz], NaN where unpaired; MAC per model mode, NaN where not by shape)
    (module docstring)."""
    n = len(mod.f_hz)
    f_out, mac_out = np.full(n, np.nan), np.full(n, np.nan)
    vis = np.flatnonzero(mod.visible)
    m = len(meas.f_hz)
    if m == 0 or len(vis) == 0:
        return f_out, mac_out
    if meas.shapes.shape[1] >= MAC_SENSORS:
        M = np.array([[mac(mod.shapes[k], meas.shapes[i]) for k in vis] for i in range(m)])
        ratio = meas.f_hz[:, None] / mod.f_hz[vis][None, :]
        M = np.where((ratio >= RATIO_RANGE[0] ** 2) & (ratio <= RATIO_RANGE[1] ** 2), M, 0.0)
        rows, cols = linear_sum_assignment(-M)
        for i, j in zip(rows, cols):
            if M[i, j] >= MAC_MIN:
                f_out[vis[j]], mac_out[vis[j]] = meas.f_hz[i], M[i, j]
        return f_out, mac_out
    best = None
    for o in range(-(m - 1), len(vis)):
        pairs = [(i, vis[i + o]) for i in range(m) if 0 <= i + o < len(vis)]
        r = np.array([meas.f_hz[i] / mod.f_hz[k] for i, k in pairs])
        ok = (r >= RATIO_RANGE[0]) & (r <= RATIO_RANGE[1])
        if not ok.any():
            continue
        key = (-int(ok.sum()), float(np.std(np.log(r[ok]))))
        if best is None or key < best[0]:
            best = (key, [p for p, good in zip(pairs, ok) if good])
    for i, k in (best[1] if best else []):
        f_out[k] = meas.f_hz[i]
    return f_out, mac_out
