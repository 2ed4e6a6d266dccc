"""Convergence of the bolted joint in its contact pitch (docs/plant.md 6, "Contact pitch").

    python -m benchmarks.contact_pitch [--pitches-mm 20 10 5 2.5 1.25] [--onset] [--set KEY=VALUE ...]
    python -m benchmarks.contact_pitch --onset-only --onset-effect none --levels 0.05 [--points]

The interface is a row of node-to-node contact points, each carrying its tributary area (SPEC 2:
the contact is per unit area, the pitch a numerical choice). Refining the pitch (elements no
longer than min(pitch, 2.5 mm)) samples the same joint; the script prints per pitch: the pairs the screws close at F_N1 = 100 N,
the preloaded stuck eigenfrequencies of modes 1-9 (plant.model.stuck_frequencies_hz of the full,
unreduced model; mode 1 is resolved only to ~0.6 % at 1.25 mm, docs/plant.md 6) and their offset
from the finest pitch, and the calibration's observable, the simulated 50 N hammer test's
mode-3 frequency and damping at 100 N (plant.impulse, as benchmarks.calibrate_contact). The joint's
pressure varies over the Winkler length lambda = (4 EI / k')^(1/4) of a beam on the contact's
foundation (k' = k_n_area x width per unit length): ~11 mm here, so pitches of 20 and 10 mm do not
resolve it.

--onset (~40 min more): the joint's slip onset per pitch, what the stuck modes do not show. Stepped
sines of the nonlinear plant at F_N1 = 300 N (rt.discrepancy.rig.levels.sweep_level: 13 lines over
0.90-1.02 of the stuck mode 3, phase-continuous up-sweeps, then two up-sweeps of 11 lines around the
largest line, each 5x finer: ``resolved_peak``) at force amplitudes ``ONSET_LEVELS_N``, with and
without micro_slip at its default spread: the peak |a_frf / F| [(m/s^2)/N] per level. Where
every pair sticks the peak is the linear one; the first pairs to slip lower it. docs/discrepancy.md,
"Which part of the model form hides an effect". ``--levels`` chooses the amplitudes.

--points: per pitch, the contact points that reach their friction limit (or open and close) at the
lowest level, driven at the stuck mode 3 (``slipping_points``; docs/plant.md 6.5: the slip zone at
the interface's end is narrower than the coarse pitches).
"""
from __future__ import annotations

import argparse
import time

import numpy as np

from frictionrt.plant.impulse import impulse_test
from frictionrt.plant.model import build_plant, preloaded_pairs, stuck_frequencies_hz
from frictionrt.plant.simulate import run
from frictionrt.plant.structure import interface_width
from frictionrt.rt.common.config import Config, load, with_sets
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.discrepancy.rig import sweep_level
from benchmarks.entry import run_main

F_N1 = 100.0
N_MODES = 9
ONSET_F_N1 = 300.0                       # [N] the rig's stuck impulse test's bolt force
ONSET_LEVELS_N = (0.05, 0.2, 0.8)        # [N] force amplitudes of the onset sweeps
ONSET_REFINE = 2                         # refinement passes around the largest line (resolved_peak)
ONSET_FINE_LINES = 11                    # lines per refinement pass


def refined(base: Config, sets: list[str], pitch: float) -> Config:
    """``base`` at contact pitch ``pitch`` [m] everywhere (unless ``sets`` give an end_refinement; the
    contact is per unit area: the same joint), elements no longer than min(pitch, 2.5 mm)."""
    return load(None, ["plant.interface.end_refinement=1"] + sets + [f"plant.interface.pitch_m={pitch!r}",
                              f"plant.element_length_m={min(base.plant.element_length_m, pitch, 0.0025)!r}"])


def winkler_length(cfg: Config) -> float:
    """lambda = (4 EI / k')^(1/4) [m]: EI of the upper beam, k' = k_n_area x width [N/m^2]."""
    beams = {b.name: b for b in cfg.plant.beams}
    up = beams[cfg.plant.interface.upper]
    EI = up.E * up.width_m * up.height_m ** 3 / 12.0
    return float((4.0 * EI / (cfg.plant.interface.k_n_area * interface_width(cfg))) ** 0.25)


def resolved_peak(model, F_N1: float, amp_n: float, lines_hz: np.ndarray, refinements: int = ONSET_REFINE) -> float:
    """Peak |a_frf / F| [(m/s^2)/N] of the up-sweep over ``lines_hz`` (rig.levels.sweep_level),
    resolved: ``refinements`` times, a new up-sweep of ``ONSET_FINE_LINES`` lines from the line below
    the largest to the one above it (each pass 5x finer), the largest of all lines kept. On the stuck
    linear FRF 13 lines 1 % apart gave 134 against a true peak of 143 (issue 31)."""
    sw = sweep_level(model, F_N1, amp_n, lines_hz)
    f, H = sw.freq_hz, np.abs(sw.H["a_frf_meas"])
    best = float(H.max())
    for _ in range(refinements):
        k = int(np.argmax(H))
        f = np.linspace(f[max(k - 1, 0)], f[min(k + 1, len(f) - 1)], ONSET_FINE_LINES)
        H = np.abs(sweep_level(model, F_N1, amp_n, f).H["a_frf_meas"])
        best = max(best, float(H.max()))
    return best


def onset_peaks(cfg: Config, levels=ONSET_LEVELS_N) -> list[float]:
    """Resolved peak |a_frf / F| [(m/s^2)/N] of mode 3 per level [N] at ``ONSET_F_N1`` (module docstring)."""
    model = build_plant(cfg)
    f3 = stuck_frequencies_hz(model, preloaded_pairs(model, ONSET_F_N1))[2]
    lines = f3 * np.linspace(0.90, 1.02, 13)
    return [resolved_peak(model, ONSET_F_N1, a, lines) for a in levels]


def slipping_points(cfg: Config, amp_n: float, seconds: float = 3.0, tail_s: float = 0.5) -> dict:
    """Which contact points act at ``amp_n`` [N] (docs/plant.md 6.5): the plant driven ``seconds``
    from its static state at ``ONSET_F_N1`` by a sine at the stuck mode 3, read over the last
    ``tail_s``. Per point x [m], closed throughout or not, the largest |f_t| / (mu f_n) while closed;
    the points that reach their limit (ratio >= 0.999) or open and close ("breathing"), the peak
    |a_frf| / F and the friction power [W] (E_fric over the tail)."""
    model = build_plant(cfg)
    f3 = stuck_frequencies_hz(model, preloaded_pairs(model, ONSET_F_N1))[2]
    dt = cfg.dt_s
    n, tail = int(round(seconds / dt)), int(round(tail_s / dt))
    Y, _, _ = run(model, amp_n * np.sin(2 * np.pi * f3 * dt * np.arange(n)), ONSET_F_N1)
    io, p = model.output_index(), model.n_pairs
    fn = Y[-tail:, [io[f"f_n_{j}"] for j in range(p)]]
    ft = Y[-tail:, [io[f"f_t_{j}"] for j in range(p)]]
    mu = cfg.plant.interface.mu
    ratio = np.where(fn > 0, np.abs(ft) / np.maximum(mu * fn, 1e-300), 0.0).max(axis=0)
    closed, open_ = (fn > 0).all(axis=0), (fn <= 0).all(axis=0)
    x = model.structure.x_pairs
    E = Y[:, io["E_fric"]]
    return {"peak": float(np.abs(Y[-tail:, io["a_frf"]]).max() / amp_n), "x": x, "ratio": ratio,
            "slipping": np.flatnonzero(closed & (ratio >= 0.999)), "breathing": np.flatnonzero(~closed & ~open_),
            "friction_W": float((E[-1] - E[-tail - 1]) / tail_s)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--pitches-mm", type=float, nargs="+", default=[20.0, 10.0, 5.0, 2.5, 1.25])
    ap.add_argument("--onset", action="store_true", help="also the slip onset's stepped sines per pitch (~40 min)")
    ap.add_argument("--onset-effect", choices=("micro_slip", "none"), default="micro_slip",
                    help="the onset also with this hidden effect at its default strength (default micro_slip)")
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--onset-only", action="store_true", help="the onset only (no stuck modes, no hammer test)")
    ap.add_argument("--levels", type=float, nargs="+", default=list(ONSET_LEVELS_N), metavar="N",
                    help=f"the onset's force amplitudes [N] (default {' '.join(f'{a:g}' for a in ONSET_LEVELS_N)})")
    ap.add_argument("--points", action="store_true",
                    help="per pitch, which points reach their friction limit at the lowest level (3 s at the stuck "
                         "mode 3; docs/plant.md 6.5), instead of the stuck modes and the hammer test")
    args = ap.parse_args(argv)
    base = load(None, args.sets)
    print(f"Winkler length of the default joint: {1e3 * winkler_length(base):.1f} mm")
    if args.points:
        print(f"\nPoints at their friction limit at {min(args.levels):g} N, F_N1 = {ONSET_F_N1:g} N, the stuck mode 3 "
              "(x from the interface's end [mm]):\n")
        print("| pitch [mm] | points | peak | slipping | breathing | largest ratio of the others | friction power [W] |")
        print("| --- " * 7 + "|", flush=True)
        for p_mm in args.pitches_mm:
            r = slipping_points(refined(base, args.sets, 1e-3 * p_mm), min(args.levels))
            at = (r["x"] - r["x"][-1]) * 1e3
            others = np.setdiff1d(np.arange(len(at)), np.concatenate([r["slipping"], r["breathing"]]))
            k = others[np.argmax(r["ratio"][others])]
            print(f"| {p_mm:g} | {len(at)} | {r['peak']:.1f} | {', '.join(f'{v:.2f}' for v in at[r['slipping']])} | "
                  f"{', '.join(f'{v:.2f}' for v in at[r['breathing']])} | {r['ratio'][k]:.2f} at {at[k]:.2f} | "
                  f"{r['friction_W']:.2e} |", flush=True)
        return 0
    if not args.onset_only:
        rows = []
        for p_mm in args.pitches_mm:
            t0 = time.perf_counter()
            cfg = refined(base, args.sets, 1e-3 * p_mm)
            full = build_plant(with_sets(cfg, ["plant.reduced=false"]))
            closed = preloaded_pairs(full, F_N1)
            f = stuck_frequencies_hz(full, closed)[:N_MODES]
            r = impulse_test(build_plant(cfg), F_N1)
            i3 = list(r.modes).index(3)
            rows.append((p_mm, int(closed.sum()), len(closed), f, float(r.freq_hz[i3]), float(r.damping_ratio[i3]),
                         time.perf_counter() - t0))
            print(f"pitch {p_mm:g} mm done ({rows[-1][-1]:.0f} s)", flush=True)
        ref = rows[-1][3]
        print(f"\nPreloaded stuck modes [Hz] at F_N1 = {F_N1:g} N (offset from the {rows[-1][0]:g} mm pitch) and the "
              "hammer test's mode 3:\n")
        print("| pitch [mm] | closed pairs | " + " | ".join(f"mode {k + 1}" for k in range(N_MODES))
              + " | hammer: mode 3 [Hz], zeta [%] |")
        print("| --- " * (N_MODES + 3) + "|")
        for p_mm, n_c, n, f, f3, z3, _ in rows:
            cells = " | ".join(f"{x:.1f} ({100 * (x / r0 - 1):+.2f} %)" for x, r0 in zip(f, ref))
            print(f"| {p_mm:g} | {n_c} / {n} | {cells} | {f3:.2f}, {100 * z3:.3f} |")
    if args.onset or args.onset_only:
        ms = None if args.onset_effect == "none" else get(args.onset_effect)
        with_ms = "" if ms is None else f", without / with {ms.name} {ms.parameter.default:g}"
        print(f"\nSlip onset: resolved peak |a_frf / F| [(m/s^2)/N] of mode 3 at F_N1 = {ONSET_F_N1:g} N{with_ms}:\n")
        print("| pitch [mm] | " + " | ".join(f"{a:g} N" for a in args.levels) + " | s |")
        print("| --- " * (len(args.levels) + 2) + "|", flush=True)
        for p_mm in args.pitches_mm:
            t0 = time.perf_counter()
            cfg = refined(base, args.sets, 1e-3 * p_mm)
            plain = onset_peaks(cfg, args.levels)
            spread = plain if ms is None else onset_peaks(ms.apply(cfg, ms.parameter.default), args.levels)
            cells = [f"{a:.1f}" if ms is None else f"{a:.1f} / {b:.1f}" for a, b in zip(plain, spread)]
            print(f"| {p_mm:g} | " + " | ".join(cells) + f" | {time.perf_counter() - t0:.0f} |", flush=True)
    return 0


if __name__ == "__main__":
    run_main(main)
