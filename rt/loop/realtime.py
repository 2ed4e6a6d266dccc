"""The process set-up of a paced run, as real-time practice has it (PREEMPT_RT guides, ros2_control's
realtime_tools): only what the loop needs, asked for, never system settings.

``session(cfg.rt, paced)`` wraps a paced run in the calling (main) thread:

- the garbage collector frozen and disabled (``gc.freeze``, ``gc.disable``): no collection
  pauses the writer or the main thread while they hold the GIL;
- with ``rt.priority`` > 0, memory locked (``mlockall(MCL_CURRENT | MCL_FUTURE)``): no page
  fault in the loop. Locking future pages makes later allocations fail once RLIMIT_MEMLOCK is
  reached, so it is done only when the limit allows the whole process (or the process may
  exceed it, as root does), else a note says so;
- ``/dev/cpu_dma_latency`` held at 0 for the run (as cyclictest does): the cores stay out of
  deep idle states, whose exit latency is tens of microseconds;
- with ``rt.cpu`` = K, the main thread (and so the writer thread it starts next) moves to the
  other cores.

``Session.enter_loop_thread()``, called by the loop's own thread before the compiled loop,
sets that thread's timer slack to 1 ns, pins it alone to core K and gives it SCHED_FIFO at
``rt.priority``. The writer and
the main thread keep the default scheduler: at FIFO priority they would compete with the loop.

Whatever the process may not do (no privilege, one core, no device) degrades to the behaviour
without it, with one note per missing piece (``Session.notes``, printed by the CLI). Nothing is
changed for a run that is not paced.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import gc
import os
import resource
import struct
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

MCL_CURRENT, MCL_FUTURE = 1, 2
PR_SET_TIMERSLACK = 29   # prctl: the thread's timer slack [ns] (default 50 us for normal threads)
DMA_LATENCY = "/dev/cpu_dma_latency"


@dataclass
class Session:
    """What a paced run got; ``notes``: one line per requested piece it did not get."""
    priority: int = 0            # SCHED_FIFO priority the loop thread runs at (0: default scheduler)
    cpu: int = -1                # core the loop thread is pinned to (-1: not pinned)
    margin_ns: int = 0           # the pacing's sleep margin [ns] (rt/loop/pacing.py)
    memory_locked: bool = False
    dma_latency_held: bool = False
    gc_frozen: bool = False
    notes: list[str] = field(default_factory=list)
    _requested_priority: int = 0
    _requested_cpu: int = -1

    def enter_loop_thread(self) -> None:
        """In the loop thread, before its compiled loop: its timer slack to 1 ns (a normal
        thread's sleeps may end up to 50 us late), pin it, raise its priority (Linux: all three
        act on the calling thread alone). Records what worked; never raises."""
        _libc().prctl(PR_SET_TIMERSLACK, 1, 0, 0, 0)
        if self._requested_cpu >= 0:
            try:
                os.sched_setaffinity(0, {self._requested_cpu})
                self.cpu = self._requested_cpu
            except OSError as exc:
                self.notes.append(f"rt.cpu {self._requested_cpu}: the loop thread cannot be pinned ({exc.strerror}); "
                                  "it runs where the scheduler puts it")
        if self._requested_priority > 0:
            try:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(self._requested_priority))
                self.priority = self._requested_priority
            except (OSError, AttributeError) as exc:
                why = getattr(exc, "strerror", None) or str(exc)
                self.notes.append(f"rt.priority {self._requested_priority}: SCHED_FIFO not permitted ({why}); the loop "
                                  "runs at normal priority (run as root, or grant CAP_SYS_NICE / an rtprio limit in "
                                  "/etc/security/limits.conf)")

    def describe(self) -> dict:
        """The JSON form (``summary``'s ``realtime``)."""
        return {"priority": self.priority, "cpu": self.cpu, "sleep_margin_us": self.margin_ns / 1e3,
                "memory_locked": self.memory_locked, "dma_latency_held": self.dma_latency_held,
                "gc_frozen": self.gc_frozen, "notes": list(self.notes)}


def margin_ns(rt_cfg) -> int:
    """The pacing's sleep margin [ns] for this configuration: ``sleep_margin_rt_us`` with a
    real-time priority, else ``sleep_margin_us``."""
    us = rt_cfg.sleep_margin_rt_us if rt_cfg.priority > 0 else rt_cfg.sleep_margin_us
    return int(round(us * 1e3))


def check_cpu(cpu: int) -> None:
    """ValueError naming the allowed cores if ``cpu`` is not one this process may run on."""
    allowed = sorted(os.sched_getaffinity(0))
    if cpu >= 0 and cpu not in allowed:
        raise ValueError(f"rt.cpu {cpu}: this process may run on cores {', '.join(map(str, allowed))}; "
                         "give one of them (--cpu K) or -1 (not pinned)")


def prefaulted(shape, dtype=np.float64) -> np.ndarray:
    """A new array of zeros whose every page has been written before the loop runs. numpy's
    ``empty`` and ``zeros`` only reserve memory: the loop's first write to each page then faults it
    in, and with transparent huge pages the kernel zeroes 2 MiB there. In `frictionrt budget
    --no-floor` (a 122 MB log, unlocked memory) that was one tick in ~1800 with a log component of
    up to 4.5..6.1 ms, the ticks the p99.9 counts. What ``mlockall(MCL_FUTURE)`` gives a locked
    process, for every run."""
    a = np.empty(shape, dtype)
    a.fill(0)
    return a


def _libc():
    return ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)


def _process_bytes() -> int:
    """The process's virtual size [bytes] (/proc/self/statm), what MCL_CURRENT would lock."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")


def _lock_memory(s: Session) -> bool:
    soft, _ = resource.getrlimit(resource.RLIMIT_MEMLOCK)
    need = _process_bytes()
    if os.geteuid() != 0 and soft != resource.RLIM_INFINITY and soft < 2 * need:
        s.notes.append(f"memory not locked: RLIMIT_MEMLOCK {soft / 2**20:.0f} MiB is below twice the process's "
                       f"{need / 2**20:.0f} MiB, and locking future pages would make later allocations fail "
                       "(ulimit -l unlimited, or memlock in /etc/security/limits.conf)")
        return False
    libc = _libc()
    if libc.mlockall(MCL_CURRENT | MCL_FUTURE) != 0:
        s.notes.append(f"memory not locked: mlockall failed ({os.strerror(ctypes.get_errno())})")
        return False
    return True


def _hold_dma_latency(s: Session) -> int | None:
    try:
        fd = os.open(DMA_LATENCY, os.O_WRONLY)
    except OSError as exc:
        s.notes.append(f"{DMA_LATENCY} not held at 0 ({exc.strerror}): the cores may enter deep idle states")
        return None
    os.write(fd, struct.pack("i", 0))
    return fd


@contextmanager
def session(rt_cfg, paced: bool):
    """The set-up around one run (module docstring); yields its ``Session``. Not paced: nothing
    is changed (the session only carries the margin)."""
    s = Session(margin_ns=margin_ns(rt_cfg), _requested_priority=rt_cfg.priority if paced else 0,
                _requested_cpu=rt_cfg.cpu if paced else -1)
    if not paced:
        yield s
        return
    check_cpu(rt_cfg.cpu)
    main_affinity = os.sched_getaffinity(0)
    fd = None
    was_enabled = gc.isenabled()
    try:
        gc.collect()
        gc.freeze()
        gc.disable()
        s.gc_frozen = True
        if rt_cfg.priority > 0:
            s.memory_locked = _lock_memory(s)
        fd = _hold_dma_latency(s)
        s.dma_latency_held = fd is not None
        if rt_cfg.cpu >= 0:
            others = main_affinity - {rt_cfg.cpu}
            if others:
                os.sched_setaffinity(0, others)
            else:
                s.notes.append(f"rt.cpu {rt_cfg.cpu} is this process's only core: the writer and Python share it "
                               "with the loop")
        yield s
    finally:
        if rt_cfg.cpu >= 0:
            os.sched_setaffinity(0, main_affinity)
        if fd is not None:
            os.close(fd)
        if s.memory_locked:
            _libc().munlockall()
        if s.gc_frozen:
            gc.unfreeze()
            if was_enabled:
                gc.enable()
