"""What the machine allows a paced loop: the null loop and cyclictest at the loop's own period.

``null_loop`` runs the loop's pacing (rt/loop/pacing.py) with an empty tick, under the same
real-time set-up (rt/loop/realtime.py): its overrun rate and lateness are the floor the paced
loop can reach on this machine with this configuration. ``cyclictest`` runs rt-tests'
cyclictest (the Linux real-time community's latency measurement; Debian package rt-tests) when
it is installed, at the same period (rounded to whole microseconds: its -i), priority and core,
with memory locked: its wake-up latencies, and the rate of those of one period or more (what
would be an overrun of a loop that sleeps to its deadline).
"""
from __future__ import annotations

import os
import shutil
import subprocess
import tempfile

import numpy as np

from frictionrt.rt.common.clock import CLK_DEADLINE, CLK_OVERRUNS, CLK_SIZE, _now_ns
from frictionrt.rt.loop import realtime
from frictionrt.rt.loop.driver import watch
from frictionrt.rt.loop.pacing import START_SLACK_NS, _null_ticks

CYCLICTEST_DEFAULT_PRIORITY = 0  # cyclictest at the loop's own priority; 0: SCHED_OTHER, as the loop
HIST_US = 2000                   # cyclictest histogram range [us]; later ones count as overflows


def tails_us(ns: np.ndarray) -> dict:
    """Median, p99, p99.9 and max of latencies ns [ns], in us."""
    us = np.asarray(ns, dtype=float) / 1e3
    return {"p50_us": float(np.median(us)), "p99_us": float(np.percentile(us, 99)),
            "p999_us": float(np.percentile(us, 99.9)), "max_us": float(us.max())}


def null_loop(rt_cfg, dt_s: float, seconds: float) -> dict:
    """The empty paced loop for ``seconds`` [s] at period dt_s [s]: ticks, overruns (missed
    periods), their rate [-], the lateness tails [us], what the real-time set-up got."""
    n = int(round(seconds / dt_s))
    period_ns = int(round(dt_s * 1e9))
    late = np.zeros(n, dtype=np.int64)
    clk = np.zeros(CLK_SIZE, dtype=np.int64)
    errors: list[BaseException] = []
    with realtime.session(rt_cfg, True) as s:
        _null_ticks(period_ns, s.margin_ns, clk, np.zeros(2, np.int64), late[:0])  # compile or load

        def worker():
            try:
                s.enter_loop_thread()
                ts = np.zeros(2, np.int64)
                clk[CLK_DEADLINE] = _now_ns(ts) + START_SLACK_NS  # as the loop: its start-up is no lateness
                _null_ticks(period_ns, s.margin_ns, clk, ts, late)
            except BaseException as exc:  # re-raised in the calling thread
                errors.append(exc)

        watch(worker, "frictionrt-null-loop", clk)
    if errors:
        raise errors[0]
    overruns = int(clk[CLK_OVERRUNS])
    return {"ticks": n, "overruns": overruns, "overrun_rate": overruns / (n + overruns),
            "late": tails_us(late), "realtime": s.describe()}


def cyclictest(rt_cfg, dt_s: float, seconds: float) -> dict | None:
    """cyclictest at the loop's period [us, rounded], priority and core for ``seconds`` [s]:
    loops, latency tails [us] (from its 1 us histogram), the count and rate of latencies of one
    period or more. None if cyclictest is not installed; {"error": ...} if it failed."""
    exe = shutil.which("cyclictest")
    if exe is None:
        return None
    interval_us = max(1, int(round(dt_s * 1e6)))
    loops = int(round(seconds / (interval_us * 1e-6)))
    with tempfile.TemporaryDirectory() as tmp:
        hist = os.path.join(tmp, "hist.txt")
        cmd = [exe, "-m", "-q", "-t", "1", "-i", str(interval_us), "-l", str(loops), "-h", str(HIST_US),
               f"--histfile={hist}", "-p", str(max(rt_cfg.priority, CYCLICTEST_DEFAULT_PRIORITY))]
        if rt_cfg.cpu >= 0:
            cmd += ["-a", str(rt_cfg.cpu)]
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=seconds * 3 + 30)
        if r.returncode != 0 or not os.path.exists(hist):
            return {"error": (r.stderr or r.stdout).strip().splitlines()[-1:] or [f"exit {r.returncode}"],
                    "command": " ".join(cmd)}
        counts, overflows = parse_histogram(open(hist).read())
    total = int(counts.sum() + overflows)
    period_us = dt_s * 1e6
    late = int(counts[int(np.ceil(period_us)):].sum() + overflows)
    cum = np.cumsum(counts)

    def pct(q):
        i = int(np.searchsorted(cum, q * total))
        return float(i) if i < len(counts) else float(HIST_US)

    return {"loops": total, "interval_us": interval_us, "late_ge_period": late, "late_rate": late / max(total, 1),
            "latency": {"p50_us": pct(0.5), "p99_us": pct(0.99), "p999_us": pct(0.999),
                        "max_us": _max_latency(counts, overflows)},
            "command": " ".join(cmd)}


def parse_histogram(text: str) -> tuple[np.ndarray, int]:
    """cyclictest's histogram file: (count per 1 us bucket from 0, overflows). ValueError if the
    text holds no histogram."""
    counts = np.zeros(HIST_US, dtype=np.int64)
    overflows = 0
    seen = False
    for line in text.splitlines():
        if line.startswith("# Histogram Overflows:"):
            overflows = int(line.split(":")[1].split()[0])
        elif line and line[0].isdigit():
            b, c = line.split()[:2]
            if int(b) < HIST_US:
                counts[int(b)] = int(c)
                seen = True
    if not seen:
        raise ValueError("no cyclictest histogram in the output")
    return counts, overflows


def _max_latency(counts: np.ndarray, overflows: int) -> float:
    nz = np.nonzero(counts)[0]
    return float(HIST_US if overflows else (nz[-1] if len(nz) else 0))
