"""The float32 kind of the C export against the double controller on run logs: per log the largest
and rms |float32 - double| of each bounded output, and the ticks where a flag differs.

    python -m benchmarks.export_float32 LOG.mcap:DIR [LOG.mcap:DIR ...] [--set KEY=VALUE ...]

DIR is an ``export-c --precision float32`` folder of the log's design (``--from-log``). Makes the
table of docs/studies/export-float32.md (rt/export/float32.py ``differences``, through
``frictionrt.rt.export.replay_c.replay_c``).
"""
from __future__ import annotations

import argparse

from frictionrt.rt.export.float32 import BOUND, DISCRETE
from frictionrt.rt.export.replay_c import replay_c


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("pairs", nargs="+", metavar="LOG.mcap:DIR")
    ap.add_argument("--set", dest="sets", action="append", default=[], help="overrides on the logs' configuration")
    a = ap.parse_args()
    print("| log | ticks | " + " | ".join(f"{c} max / rms" for c in BOUND) + " | flags differ |")
    print("| --- | --- | " + " | ".join("---" for _ in BOUND) + " | --- |")
    for pair in a.pairs:
        log, _, folder = pair.rpartition(":")
        r, _ = replay_c(log, folder, sets=a.sets)
        eq = r["equivalence"]
        flags = ", ".join(f"{c} {eq[c]['ticks_differ']}" for c in DISCRETE if eq[c]["ticks_differ"])
        print(f"| {log} | {r['ticks']} | " + " | ".join(f"{eq[c]['max_abs']:.3g} / {eq[c]['rms']:.2g}" for c in BOUND)
              + f" | {flags or 'none'} |", flush=True)


if __name__ == "__main__":
    main()
