"""Log-file benchmark: cost of writing one simulated second to MCAP and to rrd, file sizes, MCAP read.

    python benchmarks/logfiles.py [--seconds S] [--block TICKS] [--out DIR]

Runs the closed loop offline (Lyapunov law at the mode-3 resonance, 223.6 Hz, 5 N) for S
simulated seconds, then writes its log in blocks of TICKS (as the loop's writer thread will) and
prints, per simulated second: the loop's own time, write time (wall clock, and CPU time of all the
process's threads: rerun encodes in its own) and size of each format, and the MCAP read time.
"""
import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

# this folder's plant.py would shadow the plant package (Python puts the script's folder first)
sys.path = [p for p in sys.path if Path(p or ".").resolve() != Path(__file__).resolve().parent]


def benchmark(seconds: float, block: int, out: Path) -> dict:
    """Figures per simulated second: sim_s, {mcap,rrd}_write_s, {mcap,rrd}_write_cpu_s, {mcap,rrd}_MB,
    mcap_read_s."""
    from frictionrt.rt.common.config import load
    from frictionrt.rt.loop import build_loop, run
    from frictionrt.rt.log.mcap_log import McapLogWriter, read_mcap
    from frictionrt.rt.log.rrd_log import RrdLogWriter

    cfg = load(None)
    loop = build_loop(cfg, "lyapunov")
    run(loop, 223.6, 5.0, 0.01)  # compile or load the cache
    t0 = time.perf_counter()
    log = run(loop, 223.6, 5.0, seconds).log
    res = {"ticks": log.shape[0], "signals": log.shape[1], "sim_s": (time.perf_counter() - t0) / seconds}
    for fmt, new in (("mcap", lambda p: McapLogWriter(p, loop.signals, cfg.rt.rate_hz, {"benchmark": "1"})),
                     ("rrd", lambda p: RrdLogWriter(p, loop.signals, cfg.rt.rate_hz))):
        path = out / f"benchmark.{fmt}"
        t0, c0 = time.perf_counter(), time.process_time()
        with new(path) as w:
            for k0 in range(0, len(log), block):
                w.write_block(k0, log[k0:k0 + block])
        res[f"{fmt}_write_s"] = (time.perf_counter() - t0) / seconds
        res[f"{fmt}_write_cpu_s"] = (time.process_time() - c0) / seconds
        res[f"{fmt}_MB"] = path.stat().st_size / 1e6 / seconds
    t0 = time.perf_counter()
    back = read_mcap(out / "benchmark.mcap")
    res["mcap_read_s"] = (time.perf_counter() - t0) / seconds
    if not np.array_equal(back.log, log, equal_nan=True):
        raise RuntimeError("MCAP round trip differs from the log")
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=1.0, help="simulated seconds [s]")
    ap.add_argument("--block", type=int, default=2100, help="ticks per write_block (2100 = 0.1 s)")
    ap.add_argument("--out", type=Path, default=None, help="directory for the files (default: a temporary one)")
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        r = benchmark(a.seconds, a.block, a.out or Path(tmp))
    print(f"{r['ticks']} ticks x {r['signals']} signals; per simulated second:")
    print(f"  loop (offline)  {r['sim_s']:.3f} s")
    print(f"  MCAP write      {r['mcap_write_s']:.3f} s (CPU {r['mcap_write_cpu_s']:.3f} s)   {r['mcap_MB']:.1f} MB"
          f"   read {r['mcap_read_s']:.3f} s")
    print(f"  rrd write       {r['rrd_write_s']:.3f} s (CPU {r['rrd_write_cpu_s']:.3f} s)   {r['rrd_MB']:.1f} MB")


if __name__ == "__main__":
    main()
