"""Plant step benchmark: median, p99, p99.9, max [us] for 5, 9, 17, 33 contact pairs.

    python benchmarks/plant.py [--json] [--steps N]     (same as: frictionrt bench plant)
"""
import sys

from frictionrt.rt.cli import main

if __name__ == "__main__":
    sys.exit(main(["bench", "plant", *sys.argv[1:]]))
