"""Sweeps against their ticks (issue 19): what reproduce --quick, reproduce and a tune grid cost.

    python -m benchmarks.sweeps [--repeat N] [--jobs J] [--only quick,full,tune] [--json]

Each study runs as a user runs it, one fresh ``python -m frictionrt.rt.cli ... --json`` process per run
(worker start-up, design and result transfer included), and reports what its JSON says
(``frictionrt.rt.experiments.branches.sweep_timing``): simulated seconds, ticks, wall time [s], the ticks'
own time inside the compiled loop [s], the cores and the ratio wall / (tick time / cores).
With --repeat N the table gives the medians over N runs (and each run's ratio); the load
average before each run is printed beside it, since a loaded machine slows the ticks and the
rest alike but not evenly. The issue's bar: ratio <= 1.5 for the full reproduction on 2 cores,
measured with nothing else running. The full reproduction takes ~1-2 min per run on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

STUDIES = {  # name -> (command line after `python -m frictionrt.rt.cli`, where its JSON keeps the timing)
    "quick": (["reproduce", "--quick"], ("timing_s", "sweeps")),
    "full": (["reproduce"], ("timing_s", "sweeps")),
    "tune": (["tune", "--law", "hysteresis"], ("timing",)),  # the default grid: 15 candidates, modes 3, 4 at 5 N
}
FIELDS = ("simulated_s", "ticks", "wall_s", "tick_s", "cores", "tick_bound_s", "ratio")


def run_study(name: str, jobs: int, work: Path) -> dict:
    """One run of a study in a fresh process; its timing dict plus the load average before it."""
    argv, path = STUDIES[name]
    out = work / f"{name}_{len(list(work.iterdir()))}"
    load = os.getloadavg()[0]
    r = subprocess.run([sys.executable, "-m", "frictionrt.rt.cli", *argv, "--json", "--jobs", str(jobs), "--out", str(out)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(argv)} failed ({r.returncode}):\n{r.stderr[-2000:]}")
    doc = json.loads(r.stdout)
    for key in path:
        doc = doc[key]
    return {k: doc[k] for k in FIELDS} | {"load_before": load}


def median_row(runs: list[dict]) -> dict:
    """The medians of a study's runs (ticks and cores are the same in every run)."""
    return {k: statistics.median(r[k] for r in runs) for k in FIELDS + ("load_before",)}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--repeat", type=int, default=1, metavar="N", help="runs per study; the table shows medians")
    p.add_argument("--jobs", type=int, default=2, metavar="J", help="local worker processes (default 2)")
    p.add_argument("--only", default="quick,full,tune", help="studies, comma-separated (quick, full, tune)")
    p.add_argument("--json", action="store_true", help="print {study: {median: ..., runs: [...]}} as JSON")
    a = p.parse_args()
    names = [s.strip() for s in a.only.split(",") if s.strip()]
    if unknown := [s for s in names if s not in STUDIES]:
        p.error(f"--only {','.join(unknown)}: expected some of {', '.join(STUDIES)}")
    if a.repeat < 1 or a.jobs < 1:
        p.error("--repeat and --jobs must be >= 1")
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            runs = []
            for _ in range(a.repeat):
                runs.append(run_study(name, a.jobs, Path(tmp)))
                if not a.json:
                    print(f"{name}: ratio {runs[-1]['ratio']:.2f}, wall {runs[-1]['wall_s']:.1f} s "
                          f"(load {runs[-1]['load_before']:.2f} before)", file=sys.stderr)
            results[name] = {"median": median_row(runs), "runs": runs}
    if a.json:
        print(json.dumps(results))
        return 0
    print(f"{'study':<6} {'simulated [s]':>13} {'ticks':>11} {'wall [s]':>9} {'ticks own [s]':>13} {'cores':>5} "
          f"{'tick-bound [s]':>14} {'ratio':>6} {'load':>5}   (medians of {a.repeat})")
    for name, r in results.items():
        m = r["median"]
        print(f"{name:<6} {m['simulated_s']:>13.1f} {m['ticks']:>11,.0f} {m['wall_s']:>9.1f} {m['tick_s']:>13.1f} "
              f"{m['cores']:>5.0f} {m['tick_bound_s']:>14.1f} {m['ratio']:>6.2f} {m['load_before']:>5.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
