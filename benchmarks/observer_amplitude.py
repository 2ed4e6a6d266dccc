"""The amplitude-following observer's schedule and its accuracy beside the paper's observer
(docs/studies/observer-amplitude.md; the kind: frictionrt.observer.amplitude).

``--schedule``: the passive closed loop (the oracle, no law acting) at the plant's passive step-sine
peaks ``PEAKS_HZ`` (the full reproduction's); per mode and amplitude the peak over the plant's
sliding-joint linearisation at F_min (``frictionrt.plant.modes.sliding_joint_hz``) and the passive
u_rel amplitude there, mean((pi/2)|u_rel|) of the band-limited truth over the last 20 %: the
points of ``frictionrt.observer.amplitude.PLANT_PEAKS``.

Default: the bar table, both laws on each estimator kind at those peaks (``frictionrt simulate``'s
figures: NRMSE of v_rel, the law's u0 error, the |v_rel|-weighted sign error and the Lyapunov
command's F* error).

    python -m benchmarks.observer_amplitude --schedule [--duration S] [--jobs N]
    python -m benchmarks.observer_amplitude [--estimators observer amplitude] [--laws hysteresis lyapunov]
                                            [--modes 2 3 4 5] [--amps 5 10 20] [--duration S] [--jobs N]
"""
import argparse
import dataclasses
import itertools
import json
from multiprocessing import Pool

import numpy as np

from benchmarks.observer_error_sources import PEAKS_HZ
from frictionrt.observer.accuracy import band_limited_truth, tail_slice
from frictionrt.observer.amplitude import PLANT_PEAKS, design_amplitude
from frictionrt.plant.model import build_plant
from frictionrt.plant.modes import sliding_joint_hz
from frictionrt.rt.common.config import load
from frictionrt.rt.loop import build_loop, run, summary


def schedule_point(case) -> tuple:
    """(mode, F [N], f [Hz], passive u0 [m], f / f_sliding) of one passive run."""
    mode, amp, duration = case
    cfg = load()
    f = PEAKS_HZ[(mode, amp)]
    r = run(build_loop(cfg, "passive", "oracle"), f, amp, duration)
    u = band_limited_truth(r.signal("u_rel"), cfg.dt_s, cfg.observer.oracle_bandwidth_hz)
    u0 = float(np.mean(0.5 * np.pi * np.abs(u[tail_slice(len(u))])))
    f_lin = float(sliding_joint_hz(build_plant(cfg))[mode - 1])
    return mode, amp, f, u0, f / f_lin


# mode 5's passive peaks (``--schedule``), left out of PLANT_PEAKS: the "+m5" variants schedule it too
MODE5_PEAKS = ((1.546e-6, 0.98996), (2.546e-6, 0.98996), (4.541e-6, 0.98996))


def _loop(law: str, est: str):
    """The loop of ``est``; "jenkins": the amplitude-following kind with the Jenkins joint; a
    suffix "+m5": mode 5 scheduled on its passive peaks as well (``MODE5_PEAKS``)."""
    cfg = load()
    kind, _, variant = est.partition("+")
    if est in ("observer", "oracle"):
        return build_loop(cfg, law, est)
    loop = build_loop(cfg, law, "amplitude")
    peaks = PLANT_PEAKS | ({5: MODE5_PEAKS} if variant == "m5" else {})
    return dataclasses.replace(loop, amplitude=design_amplitude(cfg, loop.plant, peaks, jenkins=kind == "jenkins")[1])


def bar_cell(case) -> dict:
    law, est, mode, amp, duration = case
    f = PEAKS_HZ[(mode, amp)]
    s = summary(run(_loop(law, est), f, amp, duration))
    return {"law": law, "estimator": est, "mode": mode, "amp_n": amp, "f_hz": f} | {
        k: s.get(k, float("nan")) for k in ("v_rel_nrmse", "u_rel_nrmse", "u0_rel_error", "v_rel_sign_error",
                                             "fstar_rms_error_n", "acc045_amplitude")}


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--schedule", action="store_true", help="measure the schedule's points (passive runs)")
    ap.add_argument("--estimators", nargs="+", default=["observer", "amplitude"], choices=["observer", "oracle", "amplitude", "jenkins", "amplitude+m5", "jenkins+m5"],
                    help="jenkins: the amplitude-following kind with the joint as a Jenkins element; +m5: mode 5 "
                         "scheduled on its passive peaks too")
    ap.add_argument("--laws", nargs="+", default=["hysteresis"], choices=["hysteresis", "lyapunov"])
    ap.add_argument("--modes", type=int, nargs="+", default=[2, 3, 4, 5], choices=[2, 3, 4, 5])
    ap.add_argument("--amps", type=float, nargs="+", default=[5.0, 10.0], help="excitation amplitudes [N]")
    ap.add_argument("--duration", type=float, default=0.5)
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--json", help="also write the rows to this file")
    a = ap.parse_args()
    rows = []
    with Pool(a.jobs) as pool:
        if a.schedule:
            print("| mode | F [N] | peak [Hz] | passive u0 [um] | peak / sliding-joint linearisation |")
            print("| --- | --- | --- | --- | --- |")
            for m, amp, f, u0, ratio in pool.imap(schedule_point, [(m, amp, a.duration) for m, amp in
                                                                   itertools.product(a.modes, a.amps)]):
                rows.append({"mode": m, "amp_n": amp, "f_hz": f, "u0_m": u0, "ratio": ratio})
                print(f"| {m} | {amp:g} | {f:g} | {1e6 * u0:.3f} | {ratio:.5f} |", flush=True)
        else:
            print("| law | estimator | mode | F [N] | f [Hz] | NRMSE v_rel | NRMSE u_rel | u0 error | sign error v_rel "
                  "| F* error rms [N] | acc [m/s^2] |")
            print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
            cases = [(law, est, m, amp, a.duration) for law, m, amp, est in
                     itertools.product(a.laws, a.modes, a.amps, a.estimators)]
            for r in pool.imap(bar_cell, cases):
                rows.append(r)
                print(f"| {r['law']} | {r['estimator']} | {r['mode']} | {r['amp_n']:g} | {r['f_hz']:g} | "
                      f"{r['v_rel_nrmse']:.3f} | {r['u_rel_nrmse']:.3f} | {100 * r['u0_rel_error']:+.1f} % | "
                      f"{r['v_rel_sign_error']:.3f} | {r['fstar_rms_error_n']:.1f} | {r['acc045_amplitude']:.2f} |",
                      flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
