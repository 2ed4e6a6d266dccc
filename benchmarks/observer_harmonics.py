"""Where the observer's v_rel error sits in frequency, and which input carries it: one closed-loop run
per cell (the hysteresis law on the paper's observer with its model's normal springs at
``--spring-scale``, at the full reproduction's passive peak ``observer_error_sources.PEAKS_HZ``),
then the run-time observer step run offline on that run's logged inputs (``observer_mode5.variant_outputs``):

* "as logged": the tip velocity and force cell as the loop saw them (reproduces the loop's estimate);
* "F_cell mean": the force cell held at its mean over the last 20 %: the normal force's modulation removed;
* "v_tip low-passed": the tip velocity through a zero-phase 4th-order Butterworth at ``--cut`` x f
  (offline only: an upper bound on what removing the tip's harmonics would give).

Per variant: NRMSE(v_rel) against the band-limited truth (``frictionrt.observer.accuracy``), row by
row as ``frictionrt simulate`` reports it (``v_rel_hat[k]`` against ``v_rel[k]``), and "aligned" with the
truth one row earlier (row k's plant outputs are at t_k+1: the truth at the estimate's instant, as
the sign error takes it); the error's power (row by row) at the harmonics k f (three FFT bins each,
over whole periods of the last 20 %) as a share of the truth's power, so that the shares and the rest
add up to NRMSE^2 over those periods; and the measured tip velocity's harmonics relative to its
fundamental.

    python -m benchmarks.observer_harmonics [--modes 3 4 5] [--amps 5] [--spring-scale 0.1] [--cut 1.5]
                                            [--json OUT.json]
"""
from __future__ import annotations

import argparse
import itertools
import json
from pathlib import Path

import numpy as np

from benchmarks.entry import run_main

HARMONICS = (1, 2, 3, 4, 5, 6)


def harmonic_shares(err: np.ndarray, truth: np.ndarray, f: float, dt: float) -> dict[str, float]:
    """The error's power in the three FFT bins at each k f (``HARMONICS``) as a share of the truth's
    power, and the rest, over the whole periods at the end of the arrays (NRMSE^2 = their sum)."""
    n2 = int(round(int(len(err) * f * dt) / (f * dt)))
    E, T = np.fft.rfft(err[-n2:]), np.fft.rfft(truth[-n2:])
    fr = np.fft.rfftfreq(n2, dt)
    tot = float(np.sum(np.abs(T) ** 2))
    out = {}
    for k in HARMONICS:
        i = int(np.argmin(np.abs(fr - k * f)))
        out[f"{k}f"] = float(np.sum(np.abs(E[max(i - 1, 0):i + 2]) ** 2) / tot)
    out["rest"] = float(np.sum(np.abs(E) ** 2) / tot) - sum(out.values())
    return out


def one(mode: int, amp: float, scale: float, cut: float) -> dict:
    import scipy.signal as ss
    from benchmarks.observer_error_sources import PEAKS_HZ
    from benchmarks.observer_mode5 import variant_outputs
    from frictionrt.observer.accuracy import band_limited_truth, nrmse, tail_slice
    from frictionrt.observer.amplitude import no_amplitude
    from frictionrt.rt.common.config import load, with_sets
    from frictionrt.rt.loop import build_loop, run

    cfg = with_sets(load(), [f"observer.spring_scale={scale!r}"])
    dt, f = cfg.dt_s, PEAKS_HZ[(mode, amp)]
    loop = build_loop(cfg, "hysteresis", "observer")
    r = run(loop, f, amp, 1.0)
    v_meas, F = r.signal("v_tip_meas"), r.signal("F_cell")
    v_true = band_limited_truth(r.signal("v_rel"), dt, cfg.observer.oracle_bandwidth_hz)
    tail = tail_slice(len(v_true))
    lowpass = ss.sosfiltfilt(ss.butter(4, cut * f, fs=1.0 / dt, output="sos"), v_meas)
    inputs = {"as logged": (v_meas, F), "F_cell mean": (v_meas, np.full_like(F, F[tail].mean())),
              f"v_tip low-passed at {cut:g} f": (lowpass, F)}
    amp_none = no_amplitude(len(loop.observer.C_u) // 2)
    tip = np.abs(np.fft.rfft(v_meas[tail]))
    fr = np.fft.rfftfreq(len(v_meas[tail]), dt)
    at = lambda k: float(tip[int(np.argmin(np.abs(fr - k * f)))])  # noqa: E731
    row = {"mode": mode, "amp_n": amp, "freq_hz": f, "spring_scale": scale,
           "tip_harmonics": {f"{k}f": at(k) / at(1) for k in HARMONICS[1:]}, "variants": {}}
    for name, (v, FF) in inputs.items():
        _, v_hat, _, _ = variant_outputs(loop.observer, amp_none, v, FF)
        if name == "as logged":
            row["reproduces_loop_max_abs_m_s"] = float(np.max(np.abs(v_hat - r.signal("v_rel_hat"))))
        row["variants"][name] = {"v_rel_nrmse": nrmse(v_hat, v_true),
                                 "v_rel_nrmse_aligned": nrmse(v_hat[1:], v_true[:-1]),
                                 "shares": harmonic_shares((v_hat - v_true)[tail], v_true[tail], f, dt)}
    return row


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("--modes", type=int, nargs="+", default=[3, 4, 5], choices=[2, 3, 4, 5])
    ap.add_argument("--amps", type=float, nargs="+", default=[5.0], choices=[5.0, 10.0, 20.0])
    ap.add_argument("--spring-scale", type=float, default=0.1, help="observer.spring_scale of the observer")
    ap.add_argument("--cut", type=float, default=1.5, help="the tip velocity's low-pass, x f")
    ap.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    a = ap.parse_args(argv)
    if not 0 < a.spring_scale <= 1:
        ap.error(f"--spring-scale {a.spring_scale}: a scale in (0, 1]")
    if not a.cut > 0:
        ap.error(f"--cut {a.cut}: must be > 0")
    print("| mode | F [N] | fed | NRMSE v_rel (aligned) | " + " | ".join(f"{k}f" for k in HARMONICS)
          + " | rest | tip 2f..6f / 1f |")
    print("|" + " --- |" * (5 + len(HARMONICS) + 1))
    rows = []
    for mode, amp in itertools.product(a.modes, a.amps):
        r = one(mode, amp, a.spring_scale, a.cut)
        rows.append(r)
        tip = " ".join(f"{v:.3f}" for v in r["tip_harmonics"].values())
        for name, v in r["variants"].items():
            sh = v["shares"]
            print(f"| {mode} | {amp:g} | {name} | {v['v_rel_nrmse']:.3f} ({v['v_rel_nrmse_aligned']:.3f}) | "
                  + " | ".join(f"{sh[f'{k}f']:.4f}" for k in HARMONICS) + f" | {sh['rest']:.4f} | {tip} |", flush=True)
        if a.json:
            a.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    run_main(main)
