"""The whole tick against another tree of the project, alternating: `frictionrt budget --no-floor` A/B.

    python -m benchmarks.budget_ab OTHER_TREE [--rounds 12] [--paced-s 2] [--law lyapunov]
                                [--set-a KEY=VALUE ...] [--set-b KEY=VALUE ...]
                                [--estimator-a E] [--estimator-b E]

OTHER_TREE is another checkout of the project (e.g. `git worktree add ../base 891904d`, the tree
before issue 31), or this one (`.`) to compare two configurations: --set-a applies to OTHER_TREE's
runs, --set-b to this tree's. Each round runs `budget --no-floor --json` once in that tree and once
in this one, alternating, each in its own Python process started in the tree's folder with the
tree's own environment (TREE/.venv/bin/python where it exists: the package imports as frictionrt.*
through the environment's editable install, so another tree's code needs its own environment;
else this one's): the machine's slow and fast phases fall on both alike. Printed per tree: the median over the rounds [min..max] of the tick's median, p99 and p99.9,
the plant's median and p99.9, and the paced run's tick median and missed periods (docs/plant.md 6.4).
A run that fails is reported with its stderr's last line and the benchmark exits 1.
"""
from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

from tqdm import tqdm

from benchmarks.entry import run_main

HERE = Path(__file__).resolve().parents[1]
FIGURES = {"tick median": ("total", "median_us"), "tick p99": ("total", "p99_us"),
           "tick p99.9": ("total", "p999_us"), "plant median": ("plant", "median_us"),
           "plant p99.9": ("plant", "p999_us"), "paced tick median": ("paced", "tick_median_us"),
           "paced missed": ("paced", "overruns")}


def budget_in(tree: Path, paced_s: float, law: str, sets: list[str] = (), estimator: str | None = None) -> dict:
    """`budget --no-floor --json` run by ``tree``'s own code (its own environment where it has one);
    ``estimator`` None: the tree's default (the observer; the oracle in trees from before the
    estimator was a choice)."""
    args = ["budget", "--no-floor", "--json", "--paced-s", str(paced_s), "--law", law]
    if estimator is not None:
        args += ["--estimator", estimator]
    for kv in sets:
        args += ["--set", kv]
    # a tree from before the frictionrt.* namespace (e.g. the one an issue was filed against) imports as rt.*
    code = ("import sys\ntry:\n    from frictionrt.rt.cli import main\nexcept ModuleNotFoundError:\n"
            f"    sys.path.insert(0, '.')\n    from rt.cli import main\nsys.exit(main({args!r}))")
    venv = tree / ".venv" / "bin" / "python"
    p = subprocess.run([str(venv) if venv.exists() else sys.executable, "-c", code], cwd=tree,
                       capture_output=True, text=True)
    if p.returncode != 0:
        last = (p.stderr.strip().splitlines() or ["(no stderr)"])[-1]
        raise RuntimeError(f"budget in {tree} exited {p.returncode}: {last}")
    return json.loads(p.stdout)


def figure(res: dict, where: str, key: str) -> float:
    part = res["components"]["plant"] if where == "plant" else res[where]
    return float(part[key])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("other", type=Path, help="another checkout of the project (the A side)")
    ap.add_argument("--rounds", type=int, default=12, help="alternating runs per tree (default: 12)")
    ap.add_argument("--paced-s", type=float, default=2.0, help="paced run length [s] (default: 2)")
    ap.add_argument("--law", default="lyapunov", choices=["passive", "hysteresis", "lyapunov"])
    ap.add_argument("--set-a", action="append", default=[], metavar="KEY=VALUE", help="configuration of the A side")
    ap.add_argument("--set-b", action="append", default=[], metavar="KEY=VALUE", help="configuration of the B side")
    ap.add_argument("--estimator-a", choices=["observer", "oracle", "amplitude"],
                    help="the A side's estimator (default: its tree's own; give none for a tree from before "
                         "the choice, whose budget ran on the oracle)")
    ap.add_argument("--estimator-b", choices=["observer", "oracle", "amplitude"],
                    help="the B side's estimator (default: its tree's own, the observer)")
    args = ap.parse_args()
    if not (args.other / "rt" / "cli").is_dir():
        print(f"benchmarks.budget_ab: error: {args.other} is not a checkout of this project (no rt/cli); "
              "make one with `git worktree add DIR COMMIT`", file=sys.stderr)
        return 2
    trees = {"other": args.other.resolve(), "this": HERE}
    sets = {"other": args.set_a, "this": args.set_b}
    ests = {"other": args.estimator_a, "this": args.estimator_b}
    runs = {name: [] for name in trees}
    try:
        for _ in tqdm(range(args.rounds), desc="A/B rounds", unit="round"):
            for name, tree in trees.items():
                runs[name].append(budget_in(tree, args.paced_s, args.law, sets[name], ests[name]))
    except RuntimeError as exc:
        print(f"benchmarks.budget_ab: {exc}", file=sys.stderr)
        return 1
    head = {name: f"{trees[name]}" + (f" {' '.join(sets[name])}" if sets[name] else "")
            + (f" --estimator {ests[name]}" if ests[name] else "") for name in trees}
    print(f"| [us] | {head['other']} | {head['this']} |")
    print("| --- | --- | --- |")
    for label, (where, key) in FIGURES.items():
        cells = []
        for name in trees:
            v = [figure(r, where, key) for r in runs[name]]
            cells.append(f"{statistics.median(v):.2f} [{min(v):.2f}..{max(v):.2f}]")
        print(f"| {label} | {cells[0]} | {cells[1]} |")
    return 0


if __name__ == "__main__":
    run_main(main)
