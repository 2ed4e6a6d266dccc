"""Design time: the amplitude-following observer's schedule computed from the configuration
(``frictionrt.observer.amplitude``'s ``peaks``), instead of the default plant's measured table
``PLANT_PEAKS``.

Per scheduled mode i and excitation level F the plant's passive first-harmonic response is solved by
harmonic balance (``frictionrt.plant.harmonic_frf``, method "aft", three harmonics: the full pair law,
contact opening and closing, slip limit following the normal force) at F_N1 = tracking.F_passive_N, on
lines below the plant's sliding-joint linearisation at F_min (``frictionrt.plant.modes.sliding_joint_hz``,
``frictionrt modes``' last column), swept upwards as a step-sine is. One schedule point per (i, F):

    f_peak   vertex of the parabola through the line of largest |H_frf| and its two neighbours [Hz]
    a        |u_rel^| at that line, the first harmonic of the damper's relative displacement [m]
    r        f_peak / f_sliding,i

the same pair (passive u_rel amplitude at the peak, peak over the linearisation) that ``PLANT_PEAKS``
holds from the step-sine of the closed loop. Costly (0.1-1.7 s a line, docs/plant.md 10): the result
is cached as JSON under $XDG_CACHE_HOME/frictionrt/amplitude-schedule/, keyed by the SHA-256 of the
configuration's plant (``plant_key``) and the arguments.
"""
from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from pathlib import Path

import numpy as np

from frictionrt.rt.common.config import Config

MODES = (2, 3, 4)              # the modes PLANT_PEAKS schedules (mode 5 is left out on purpose: observer.amplitude)
LEVELS_N = (5.0, 10.0)         # excitation force amplitudes [N]
LINES = tuple(np.round(np.arange(0.965, 1.0001, 0.005), 4))   # lines as fractions of the sliding-joint frequency


def plant_key(cfg: Config) -> str:
    """SHA-256 of what the schedule depends on: the plant and actuator sections and the passive
    preloads tracking.F_min_N, F_passive_N (not the law, the sensors, the loop's rate or seed)."""
    parts = [repr(dataclasses.asdict(cfg.plant)), repr(dataclasses.asdict(cfg.actuator)),
             repr((cfg.tracking.F_min_N, cfg.tracking.F_passive_N))]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def cache_file(cfg: Config, modes, levels_n, lines) -> Path:
    """Where the schedule of this configuration's plant (``plant_key``) and these arguments is cached
    (module docstring)."""
    key = hashlib.sha256((plant_key(cfg) + json.dumps([list(modes), list(levels_n), [float(x) for x in lines]]))
                         .encode()).hexdigest()
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "frictionrt" / "amplitude-schedule" / f"{key[:32]}.json"


def _vertex(f: np.ndarray, h: np.ndarray) -> tuple[float, int]:
    """(vertex [Hz] of the parabola through the largest |h| and its neighbours, index of that line);
    the line itself at an end of the grid."""
    k = int(np.nanargmax(h))
    if 0 < k < len(f) - 1 and np.all(np.isfinite(h[k - 1:k + 2])):
        c = np.polyfit(f[k - 1:k + 2] - f[k], h[k - 1:k + 2], 2)
        if c[0] < 0:
            return float(f[k] - c[1] / (2 * c[0])), k
    return float(f[k]), k


def harmonic_peaks(cfg: Config, plant=None, modes=MODES, levels_n=LEVELS_N, lines=LINES,
                   use_cache: bool = True, on_point=None) -> dict[int, tuple[tuple[float, float], ...]]:
    """{mode: ((a [m], r), ...)} sorted by a (module docstring), the ``peaks`` argument of
    ``design_amplitude``. A level whose peak lies at an end of the lines, or where the balance did
    not converge on the peak's three lines, gives no point (the cache's "rows" say which and why);
    a mode without any point keeps r = 1. ``on_point(row)``: called after each level (progress)."""
    path = cache_file(cfg, modes, levels_n, lines)
    if use_cache and path.is_file():
        data = json.loads(path.read_text())
        return {int(m): tuple((float(a), float(r)) for a, r in pts) for m, pts in data["peaks"].items()}
    from frictionrt.plant.harmonic_frf import U_REL, harmonic_accelerances, harmonic_system
    from frictionrt.plant.model import build_plant
    from frictionrt.plant.modes import sliding_joint_hz
    plant = build_plant(cfg) if plant is None else plant
    f_lin = sliding_joint_hz(plant, cfg.tracking.F_min_N)
    hs = harmonic_system(plant, {"a": cfg.plant.frf_point, "u": U_REL}, cfg.tracking.F_passive_N)
    out: dict[int, list] = {}
    rows = []
    for mode in modes:
        f_s = float(f_lin[mode - 1])
        f = f_s * np.asarray(lines, dtype=float)
        for F in levels_n:
            res = harmonic_accelerances(hs, F, f, method="aft", n_harm=3, branches=False)
            h = np.abs(res.H["a"])
            f_peak, k = _vertex(f, h)
            row = {"mode": mode, "F_N": F, "f_sliding_hz": f_s, "converged": int(res.converged.sum()),
                   "lines": len(f), "H_abs": [round(float(x), 4) for x in h]}
            if not (0 < k < len(f) - 1) or not res.converged[k - 1:k + 2].all():
                row["skipped"] = "the peak at an end of the lines or not converged around it"   # no point, as
                # the measured table leaves out a level whose peak it could not place
            else:
                a = float(np.abs(res.H["u"][k]) * F / (2 * np.pi * f[k]) ** 2)
                out.setdefault(mode, []).append((a, f_peak / f_s))
                row |= {"f_peak_hz": f_peak, "u_rel_amp_m": a, "ratio": f_peak / f_s}
            rows.append(row)
            if on_point is not None:
                on_point(row)
    peaks = {m: tuple(sorted(v)) for m, v in out.items()}
    if use_cache:
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(".tmp")
        tmp.write_text(json.dumps({"peaks": {str(m): v for m, v in peaks.items()}, "rows": rows}, indent=1))
        tmp.replace(path)
    return peaks
