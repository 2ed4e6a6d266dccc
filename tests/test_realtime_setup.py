"""The paced loop's real-time set-up and pacing (issue 19): deadlines, sleep-then-spin, the null
loop, cyclictest's histogram, and that every missing privilege degrades to a one-line note.

Timing here is checked only where it cannot be flaky (a wait ends after its deadline; a sleep
costs no CPU); the overrun rates themselves are measured by ``frictionrt budget`` and
benchmarks/soak.py, not asserted.
"""
from __future__ import annotations

import os
import resource
import threading
import time

import numpy as np
import pytest

from frictionrt.rt.cli import main
from frictionrt.rt.common.clock import CLK_DEADLINE, CLK_OVERRUNS, CLK_SIZE, _now_ns
from frictionrt.rt.common.config import load, with_sets
from frictionrt.rt.loop import realtime
from frictionrt.rt.loop.floor import cyclictest, null_loop, parse_histogram
from frictionrt.rt.loop.pacing import _next_deadline, _wait_for_deadline

PERIOD = 47_619


def test_next_deadline_skips_whole_periods_and_counts_them():
    clk = np.zeros(CLK_SIZE, dtype=np.int64)
    clk[CLK_DEADLINE] = 1_000_000
    assert not _next_deadline(clk, PERIOD, 1_000_000 + PERIOD - 1)     # ended before the next deadline
    assert clk[CLK_DEADLINE] == 1_000_000 + PERIOD and clk[CLK_OVERRUNS] == 0
    # a tick ending 2.5 periods past its next deadline misses 3 periods; the deadline stays on the grid
    t_end = clk[CLK_DEADLINE] + PERIOD + int(2.5 * PERIOD)
    assert _next_deadline(clk, PERIOD, t_end)
    assert clk[CLK_OVERRUNS] == 3
    assert clk[CLK_DEADLINE] == 1_000_000 + 5 * PERIOD and clk[CLK_DEADLINE] > t_end


@pytest.mark.timing
def test_wait_sleeps_until_the_margin_then_spins_to_the_deadline():
    # 20 ms ahead, 2 ms margin: the wait ends at or after the deadline, and the thread spends
    # about the margin on the CPU, not the 20 ms (thread CPU time; a pure spin spends all of it)
    ts = np.zeros(2, np.int64)
    clk = np.zeros(CLK_SIZE, dtype=np.int64)
    _wait_for_deadline(clk, ts, 0)  # compile or load
    for margin_ns, most_cpu_s in ((2_000_000, 0.012), (10**9, None)):
        clk[CLK_DEADLINE] = _now_ns(ts) + 20_000_000
        c0 = time.thread_time()
        _wait_for_deadline(clk, ts, margin_ns)
        cpu = time.thread_time() - c0
        assert _now_ns(ts) >= clk[CLK_DEADLINE]
        if most_cpu_s is not None:
            assert cpu < most_cpu_s, f"the wait spent {cpu * 1e3:.1f} ms of CPU: it did not sleep"
        else:
            assert cpu > 0.005, f"a margin over the wait is a pure spin, yet it spent only {cpu * 1e3:.1f} ms"


def test_null_loop_keeps_its_deadlines():
    cfg = load()
    r = null_loop(cfg.rt, cfg.dt_s, 0.2)
    assert r["ticks"] == 4200 and r["overruns"] >= 0  # under load a spinning thread without priority misses many
    assert r["overrun_rate"] == r["overruns"] / (r["ticks"] + r["overruns"])
    lt = r["late"]
    assert 0 <= lt["p50_us"] <= lt["p99_us"] <= lt["p999_us"] <= lt["max_us"]
    assert r["realtime"]["gc_frozen"] and r["realtime"]["priority"] == 0


HIST = """# Histogram
000000 000000
000001 000900
000002 000050
000047 000001
000048 000002
000120 000003
# Total: 000000959
# Min Latencies: 00001
# Avg Latencies: 00001
# Max Latencies: 02500
# Histogram Overflows: 00004
# Histogram Overflow at cycle number:
# Thread 0: 00010 00020 00030 00040
"""


def test_cyclictest_histogram_is_parsed_and_missing_cyclictest_is_none(monkeypatch):
    counts, overflows = parse_histogram(HIST)
    assert counts[1] == 900 and counts[48] == 2 and counts[120] == 3 and overflows == 4
    assert counts.sum() + overflows == 960
    with pytest.raises(ValueError, match="no cyclictest histogram"):
        parse_histogram("# nothing\n")
    monkeypatch.setattr("shutil.which", lambda name: None)
    assert cyclictest(load().rt, load().dt_s, 0.1) is None


def test_missing_privileges_degrade_to_notes(monkeypatch):
    # no SCHED_FIFO, no memory lock under a small RLIMIT_MEMLOCK, no /dev/cpu_dma_latency: the run
    # goes on without them, one note each
    def refuse(*a):
        raise PermissionError(1, "Operation not permitted")
    monkeypatch.setattr(os, "sched_setscheduler", refuse)
    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    monkeypatch.setattr(resource, "getrlimit", lambda which: (8 * 2**20, 8 * 2**20))
    monkeypatch.setattr(realtime, "DMA_LATENCY", "/nonexistent/cpu_dma_latency")
    rt_cfg = with_sets(load(), ["rt.priority=50"]).rt
    with realtime.session(rt_cfg, True) as s:
        t = threading.Thread(target=s.enter_loop_thread)
        t.start()
        t.join()
    d = s.describe()
    assert d["priority"] == 0 and not d["memory_locked"] and not d["dma_latency_held"]
    notes = " | ".join(d["notes"])
    assert "SCHED_FIFO not permitted" in notes and "RLIMIT_MEMLOCK" in notes and "cpu_dma_latency" in notes
    assert len(d["notes"]) == 3


def test_an_offline_session_changes_nothing():
    affinity = os.sched_getaffinity(0)
    with realtime.session(with_sets(load(), ["rt.priority=50", "rt.cpu=0"]).rt, False) as s:
        assert os.sched_getaffinity(0) == affinity
    assert s.describe()["notes"] == [] and not s.gc_frozen and s.priority == 0


def test_pinning_moves_the_main_thread_off_the_loop_core_and_back():
    cores = sorted(os.sched_getaffinity(0))
    if len(cores) < 2:
        pytest.skip("one core: nothing to move")
    before = os.sched_getaffinity(0)
    seen = {}
    with realtime.session(with_sets(load(), [f"rt.cpu={cores[-1]}"]).rt, True) as s:
        seen["main"] = os.sched_getaffinity(0)
        t = threading.Thread(target=lambda: (s.enter_loop_thread(), seen.__setitem__("loop", os.sched_getaffinity(0))))
        t.start()
        t.join()
    assert seen["loop"] == {cores[-1]} and cores[-1] not in seen["main"]
    assert os.sched_getaffinity(0) == before and s.cpu == cores[-1]


def test_cli_refuses_realtime_options_without_paced_and_a_core_it_may_not_use(capsys):
    assert main(["simulate", "--law", "passive", "--freq", "205", "--amp", "1", "--duration", "0.01",
                 "--rt-priority", "50"]) == 2
    assert "add --paced" in capsys.readouterr().err
    bad = max(os.sched_getaffinity(0)) + 1
    assert main(["simulate", "--paced", "--law", "passive", "--freq", "205", "--amp", "1", "--duration", "0.01",
                 "--cpu", str(bad)]) == 2
    err = capsys.readouterr().err
    assert f"rt.cpu {bad}" in err and "give one of them" in err


def _resident_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def test_prefaulted_arrays_are_resident_before_the_loop_writes():
    """The loop's log is allocated by realtime.prefaulted: every page written once before the loop
    runs, so that no first write inside it faults (docs/loop.md). numpy's empty reserves without
    making anything resident (64 MiB: under 1 MiB grows), prefaulted makes all of it resident
    (at least 60 of 64 MiB; a huge page may round up)."""
    n = 64 * 2**20 // 8
    r0 = _resident_bytes()
    lazy = np.empty(n)
    r1 = _resident_bytes()
    faulted = realtime.prefaulted(n)
    r2 = _resident_bytes()
    assert r1 - r0 < 2**20
    assert r2 - r1 >= 60 * 2**20
    assert faulted.dtype == np.float64 and not faulted.any()
    assert realtime.prefaulted((3, 2), np.int64).dtype == np.int64
    assert lazy.size == n   # kept alive until r1 was read
