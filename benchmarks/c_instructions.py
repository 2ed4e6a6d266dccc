"""Instructions per tick of exported C controllers on the same readings (valgrind callgrind around
``ctrl_step``), and their objects' size: docs/export-c.md, "The amplitude-following observer".

    python -m benchmarks.c_instructions DIR [DIR ...] [--readings FROM_DIR] [--ticks 1200]

Each DIR is a ``frictionrt export-c`` folder (observer builds); the readings are the first ``--ticks``
ticks of FROM_DIR's golden stream (default: the first DIR's; before its dropout and range fault at
40 % and 70 %), written as the harness's input (hexadecimal floats). Needs valgrind, make and cc.
"""
import argparse
import re
import subprocess
import tempfile
from pathlib import Path

import numpy as np


def harness_input(folder: Path, ticks: int) -> str:
    """The first ``ticks`` lines of folder's golden_in.txt as ctrl_harness input lines."""
    rows = [ln.split() for ln in (folder / "golden_in.txt").read_text().splitlines() if not ln.startswith("#")]
    out = []
    for r in rows[:ticks]:
        v = np.array([int(x, 16) for x in r[1:5]], dtype=np.uint64).view(np.float64)
        out.append(f"{int(r[0], 16)} " + " ".join(float(x).hex() for x in v) + f" {int(r[5], 16)}")
    return "\n".join(out) + "\n"


def instructions(folder: Path, readings: str, work: Path) -> tuple[int, int]:
    """(instructions in ctrl_step over the readings, text bytes of frictionrt_ctrl.o)."""
    subprocess.run(["make", "-s", "-C", str(folder), "ctrl_harness"], check=True, capture_output=True)
    out = work / f"cg_{folder.name}.out"
    p = subprocess.run(["valgrind", "--tool=callgrind", "--toggle-collect=ctrl_step", f"--callgrind-out-file={out}",
                        str(folder / "ctrl_harness")], input=readings, capture_output=True, text=True, check=True)
    n = int(re.search(r"Collected : (\d+)", p.stderr).group(1))
    size = subprocess.run(["size", str(folder / "frictionrt_ctrl.o")], capture_output=True, text=True, check=True)
    return n, int(size.stdout.splitlines()[1].split()[0])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", type=Path)
    ap.add_argument("--readings", type=Path, default=None)
    ap.add_argument("--ticks", type=int, default=1200)
    a = ap.parse_args()
    readings = harness_input(a.readings or a.dirs[0], a.ticks)
    print("| export | estimator | instructions per tick | object code and constants [B] |\n| --- | --- | --- | --- |")
    with tempfile.TemporaryDirectory() as work:
        for d in a.dirs:
            n, size = instructions(d, readings, Path(work))
            est = re.search(r'"estimator": "(\w+)"', (d / "frictionrt_export.json").read_text()).group(1)
            print(f"| {d} | {est} | {n / a.ticks:.0f} | {size} |")


if __name__ == "__main__":
    main()
