"""The amplitude-following observer's schedule computed from the configuration by harmonic balance
(``frictionrt.observer.amplitude_schedule.harmonic_peaks``) against the default plant's measured table
``frictionrt.observer.amplitude.PLANT_PEAKS`` (step-sine peaks of the passive closed loop):
docs/studies/observer-amplitude-c.md.

    python -m benchmarks.amplitude_schedule [--modes 2 3 4] [--levels 5 10] [--no-cache] [--set K=V ...]

Prints per mode and level the harmonic balance's peak, u_rel amplitude and ratio, the measured
table's ratio interpolated at that amplitude (``frequency_ratios``'s rule: 1 at 0, linear, held),
their difference, and the wall time.
"""
import argparse
import json
import time

import numpy as np

from frictionrt.observer.amplitude import PLANT_PEAKS
from frictionrt.observer.amplitude_schedule import LEVELS_N, MODES, cache_file, harmonic_peaks
from frictionrt.rt.common.config import load


def table_ratio(mode: int, a: float) -> float:
    pts = PLANT_PEAKS.get(mode, ())
    x = np.concatenate([[0.0], [p[0] for p in pts]])
    y = np.concatenate([[1.0], [p[1] for p in pts]])
    return float(np.interp(a, x, y))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--modes", nargs="+", type=int, default=list(MODES))
    ap.add_argument("--levels", nargs="+", type=float, default=list(LEVELS_N))
    ap.add_argument("--no-cache", action="store_true")
    ap.add_argument("--set", dest="sets", action="append", default=[])
    a = ap.parse_args()
    cfg = load(sets=a.sets)
    t = time.perf_counter()
    peaks = harmonic_peaks(cfg, modes=a.modes, levels_n=a.levels, use_cache=not a.no_cache,
                           on_point=lambda row: print(json.dumps(row), flush=True))
    wall = time.perf_counter() - t
    print("| mode | u_rel amp [um] | r harmonic balance | r table (interpolated) | difference |\n| --- | --- | --- | --- | --- |")
    for mode, pts in peaks.items():
        for amp, r in pts:
            rt = table_ratio(mode, amp)
            print(f"| {mode} | {amp * 1e6:.3f} | {r:.5f} | {rt:.5f} | {r - rt:+.5f} |")
    print(f"wall {wall:.1f} s; cache {cache_file(cfg, a.modes, a.levels, __import__('frictionrt.observer.amplitude_schedule', fromlist=['LINES']).LINES)}")


if __name__ == "__main__":
    main()
