"""The adaptive screw's joint as the paper's control design sees it: a Jenkins element fitted to
the model's own hysteresis loops F_t(u_rel) (docs/plant.md 6, issue 15 item 4).

    python -m benchmarks.jenkins_fit [--freq HZ] [--forces 40 100 300] [--amps 5 20] [--plot F.png]

For each constant F_N1 (the stack held at its voltage) and excitation amplitude, a closed-loop
run of 1 s at ``--freq`` (default: the passive mode-3 resonance); over the last 10 cycles the
tangential force of the pairs inside the adaptive screw's pressure cone, F_t = sum f_t,j, against
u_rel. Fitted per loop: the slip force F_s = (max F_t - min F_t) / 2, the stuck stiffness k_T
= the slope of F_t over the first 20 % of each branch's travel after a reversal (least squares;
the reversals are u_rel's extremes per half period), the loop
energy W = closed integral of F_t du_rel, and the Jenkins energy 4 F_s (u0 - F_s / k_T) it
implies; mu_eff = F_s / F_N1. Eq. 3's optimal gain for the fitted joint is K_f = k_T / (2 mu_eff).
"""
from __future__ import annotations

import argparse
import json

import numpy as np

from frictionrt.plant.structure import adaptive_cone_pairs
from frictionrt.rt.common.config import load
from frictionrt.rt.loop import build_loop, run
from benchmarks.entry import run_main


def loop_fit(u: np.ndarray, F: np.ndarray, period_samples: float) -> dict:
    """Jenkins parameters of one steady loop (module docstring). The reversals are the extremes of
    u within each half period (``period_samples``: samples per excitation period): the sampled
    u_rel carries the unresolved modes' ringing, whose own reversals made every other branch a few
    samples long and the slope's median 0 (stop 43: k_T 0 N/m at 40 N on the graded joint)."""
    u0 = 0.5 * (u.max() - u.min())
    F_s = 0.5 * (F.max() - F.min())
    du = np.diff(u)
    half = max(2, int(round(0.5 * period_samples)))
    rev = []
    for a in range(0, len(u) - half + 1, half):
        w = u[a:a + half]
        i = a + int(np.argmax(w) if (not rev or u[rev[-1]] < np.mean(w)) else np.argmin(w))
        if not rev or i > rev[-1]:
            rev.append(i)
    slopes = []
    for a, b in zip(rev[:-1], rev[1:]):
        travel = np.abs(u[a:b] - u[a])
        near = travel <= 0.2 * travel.max()   # the first 20 % of the branch's travel
        if near.sum() >= 3 and np.ptp(u[a:b][near]) > 0:
            slopes.append(np.polyfit(u[a:b][near], F[a:b][near], 1)[0])
    k_T = float(np.median(slopes)) if slopes else float("nan")
    W = abs(float(np.sum(0.5 * (F[1:] + F[:-1]) * du)))   # the loop's area: energy dissipated per 10 cycles
    return {"u0_m": float(u0), "F_s_N": float(F_s), "k_T_N_per_m": k_T, "W_J": W,
            "W_jenkins_J": float(4 * F_s * max(0.0, u0 - F_s / k_T)) if k_T > 0 else float("nan")}


def fit(cfg, F_N1: float, amp: float, freq: float) -> dict:
    """The fitted loop of a passive run with the stack held at F_N1 [N] (cfg's tracking.F_passive_N)."""
    loop = build_loop(cfg, "passive", "oracle")
    r = run(loop, freq, amp, 1.0)
    pairs = np.flatnonzero(adaptive_cone_pairs(loop.cfg, loop.plant.structure.x_pairs))
    n = int(round(10 / freq / loop.cfg.dt_s))
    u = r.signal("u_rel")[-n:]
    F = sum(r.signal(f"f_t_{j}")[-n:] for j in pairs)
    out = loop_fit(u, F, 1.0 / (freq * loop.cfg.dt_s))
    out |= {"F_N1_N": F_N1, "amp_n": amp, "freq_hz": freq, "pairs": [int(j) for j in pairs],
            "mu_eff": out["F_s_N"] / F_N1, "F_N1_mean_N": float(np.mean(r.signal("F_N1")[-n:]))}
    return out


def main(argv=None) -> int:
    from frictionrt.rt.common.config import with_sets
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--freq", type=float, required=True, help="excitation frequency [Hz] (a resonance)")
    ap.add_argument("--forces", type=float, nargs="+", default=[40.0, 100.0, 300.0])
    ap.add_argument("--amps", type=float, nargs="+", default=[5.0, 20.0])
    ap.add_argument("--set", action="append", default=[], dest="sets")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    base = load(None, args.sets)
    rows = []
    for F in args.forces:
        for a in args.amps:
            cfg = with_sets(base, [f"tracking.F_passive_N={float(F)!r}"])
            r = fit(cfg, F, a, args.freq)
            rows.append(r)
            if not args.json:
                print(f"F_N1 {F:5.0f} N, {a:4.0f} N at {args.freq:g} Hz: u0 {r['u0_m'] * 1e6:7.3f} um, F_s {r['F_s_N']:7.2f} N "
                      f"(mu_eff {r['mu_eff']:.3f}), k_T {r['k_T_N_per_m']:.3g} N/m, W {r['W_J'] * 1e6:.3f} uJ "
                      f"(Jenkins {r['W_jenkins_J'] * 1e6:.3f}), K_f = k_T/(2 mu) {r['k_T_N_per_m'] / (2 * r['mu_eff']):.3g} N/m",
                      flush=True)
    if args.json:
        print(json.dumps(rows))
    return 0


if __name__ == "__main__":
    run_main(main)
