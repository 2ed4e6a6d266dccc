"""Does the plant behave like a bolted rig? The figures of docs/plant.md section 9 (issue 15).

    python -m benchmarks.plant_fidelity runs --freqs F3 F4 [--laws passive hysteresis lyapunov] [--json]

``runs``: closed-loop runs of 1 s at the passive mode-3 and mode-4 resonances, 5 and 20 N; per
run the share of the plant's a_frf energy (0..10.5 kHz, last 0.5 s) within +-5 % of the
excitation frequency and its first 9 harmonics, a_frf rms over first-harmonic amplitude / sqrt 2,
and the largest normal gap of the pairs within 15 mm of each screw. The constant-F_N1 baseline
(the step-sine peak per constant F_N1 and its one-minimum check) is benchmarks/baseline_curve.py.
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from frictionrt.rt.common.config import load
from frictionrt.rt.loop import build_loop, run
from benchmarks.entry import run_main

HARMONICS = 10      # the excitation frequency and its first 9 harmonics
BAND = 0.05         # +-5 % around each
NEAR_SCREW_M = 0.015


def harmonic_share(x: np.ndarray, f0: float, dt: float) -> tuple[float, float]:
    """(share of the energy of x within +-BAND f of f0 .. HARMONICS f0, rms / (A1 / sqrt 2)) with
    A1 the first-harmonic amplitude (a least-squares fit at f0)."""
    x = np.asarray(x, float) - np.mean(x)
    n = len(x)
    X = np.abs(np.fft.rfft(x * np.hanning(n))) ** 2
    f = np.fft.rfftfreq(n, dt)
    near = np.zeros_like(f, bool)
    for h in range(1, HARMONICS + 1):
        near |= np.abs(f - h * f0) <= BAND * h * f0
    t = np.arange(n) * dt
    A = np.column_stack([np.cos(2 * np.pi * f0 * t), np.sin(2 * np.pi * f0 * t)])
    c = np.linalg.lstsq(A, x, rcond=None)[0]
    a1 = float(np.hypot(*c))
    return float(X[near].sum() / X.sum()), float(np.sqrt(np.mean(x ** 2)) / (a1 / np.sqrt(2.0)))


def near_screw_pairs(loop) -> list[int]:
    st = loop.plant.structure
    xs = [s.x_m for s in loop.cfg.plant.screws]
    return [j for j, x in enumerate(st.x_pairs) if min(abs(x - s) for s in xs) <= NEAR_SCREW_M + 1e-12]


def fidelity(cfg, law: str, freq: float, amp: float, duration: float = 1.0, estimator: str = "oracle") -> dict:
    """The run's figures (module docstring)."""
    loop = build_loop(cfg, law, estimator)
    r = run(loop, freq, amp, duration)
    dt = cfg.dt_s
    tail = slice(len(r.log) // 2, None)
    a = r.signal("a_frf")[tail]
    share, ratio = harmonic_share(a, freq, dt)
    pairs = near_screw_pairs(loop)
    gmax = {j: float(r.signal(f"g_n_{j}")[tail].max()) for j in pairs}
    return {"law": law, "freq_hz": freq, "amp_n": amp, "harmonic_share": share, "rms_over_h1": ratio,
            "a_frf_rms": float(np.sqrt(np.mean((a - a.mean()) ** 2))),
            "near_screw_max_gap_m": gmax, "near_screw_closed": all(g < 0.0 for g in gmax.values()),
            "F_N1_min": float(r.signal("F_N1")[tail].min()), "F_N1_max": float(r.signal("F_N1")[tail].max())}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="what", required=True)
    a = sub.add_parser("runs")
    a.add_argument("--laws", nargs="+", default=["passive", "hysteresis", "lyapunov"])
    a.add_argument("--freqs", nargs="+", type=float, required=True, help="excitation frequencies [Hz]")
    a.add_argument("--amps", nargs="+", type=float, default=[5.0, 20.0])
    a.add_argument("--set", action="append", default=[], dest="sets")
    a.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    cfg = load(None, args.sets)
    rows = []
    for law in args.laws:
        for f in args.freqs:
            for amp in args.amps:
                r = fidelity(cfg, law, f, amp)
                rows.append(r)
                if not args.json:
                    g = ", ".join(f"{j}: {v * 1e6:.3f}" for j, v in r["near_screw_max_gap_m"].items())
                    print(f"{law:>10} {f:7.1f} Hz {amp:4.0f} N: harmonic share {r['harmonic_share']:.3f}, "
                          f"rms/(A1/sqrt2) {r['rms_over_h1']:.3f}, F_N1 {r['F_N1_min']:.1f}..{r['F_N1_max']:.1f} N, "
                          f"max gap near screws [um] {g}", flush=True)
    if args.json:
        print(json.dumps(rows))
    return 0


if __name__ == "__main__":
    run_main(main)
