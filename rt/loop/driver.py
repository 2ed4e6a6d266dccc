"""``run``: the thread that drives the compiled tick (rt/loop/tick.py) through a run, in chunks,
with progress, Ctrl-C as a stop request and a log writer draining a ring (or, for a step-sine's
short blocks, the calling thread); ``Run``, its result.
"""
from __future__ import annotations

import math
import threading
from dataclasses import dataclass

import numpy as np

from frictionrt.plant.actuator import output_index as actuator_output_index
from frictionrt.plant.sensors import output_index as sensor_output_index
from frictionrt.rt.common.clock import CLK_DEADLINE, CLK_OVERRUNS, CLK_SIZE, CLK_STOP, CLK_TICKS, CLK_WRITTEN, NO_WAIT, _now_ns
from frictionrt.rt.loop import realtime
from frictionrt.rt.loop.build import COMPONENTS, Loop, LoopState, controller_stages, initial_loop_state
from frictionrt.rt.loop.keyframe import keyframe_parts, layout, no_keyframes, ring_rows, views, widths
from frictionrt.rt.loop.pacing import START_SLACK_NS
from frictionrt.rt.loop.supervisor import F_END, F_KIND, F_START, F_TARGET, K_DROPOUT, no_faults
from frictionrt.rt.loop.tick import _run_ticks


@dataclass
class Run:
    """A finished (or interrupted) run: the log and its figures."""
    loop: Loop
    freq_hz: float
    amp_n: float
    log: np.ndarray            # (rows, len(loop.signals)): every tick, or a ring run's last rows (``run``)
    comp_ns: np.ndarray | None  # (rows, len(COMPONENTS)) if timed, the same ticks
    overruns: int
    paced: bool
    wall_ns: int
    interrupted: bool = False  # stopped by Ctrl-C: the log holds the ticks run until then
    final: LoopState | None = None  # every state after the last tick run (a next run's start)
    faults: np.ndarray | None = None  # the injected fault schedule (rt.loop.faults)
    ticks: int | None = None  # ticks run (None: len(log), every tick held)
    digest: object = None  # a ring run's whole-run figures (rt.loop.digest.RunDigest), if its writer kept them
    realtime: dict | None = None  # paced: what the real-time set-up got (rt.loop.realtime.Session.describe)

    def __post_init__(self):
        if self.ticks is None:
            self.ticks = len(self.log)

    def signal(self, name: str) -> np.ndarray:
        return self.log[:, self.loop.column(name)]


MAX_LOG_BYTES = 4 * 2**30  # a run's log must fit in memory with room to spare


def check_run_input(loop: Loop, freq_hz: float, amp_n: float, duration_s: float, ring: bool = False) -> int:
    """Number of ticks of a run; ValueError (naming the option and the limit) for an excitation
    frequency outside (0, Nyquist) (the one range of every verb: a sine at 0 Hz has no harmonic
    to measure), a negative amplitude or duration, or (without a ring: ``run``) a log
    that would not fit in memory."""
    dt = loop.cfg.dt_s
    nyq = 0.5 / dt
    if not (math.isfinite(freq_hz) and 0.0 < freq_hz < nyq):
        raise ValueError(f"--freq {freq_hz:g} Hz: give a frequency in (0, {nyq:g}) Hz (above 0, below Nyquist)")
    if not (math.isfinite(amp_n) and amp_n >= 0.0):
        raise ValueError(f"--amp {amp_n:g} N: must be a finite force >= 0 N")
    if not (math.isfinite(duration_s) and duration_s > 0.0):
        raise ValueError(f"--duration {duration_s:g} s: must be > 0 s")
    n_ticks = int(round(duration_s / dt))
    n_sig = len(loop.signals)
    if not ring and n_ticks * n_sig * 8 > MAX_LOG_BYTES:
        raise ValueError(f"--duration {duration_s:g} s: the log would need "
                         f"{n_ticks * n_sig * 8 / 2**30:.1f} GiB (> {MAX_LOG_BYTES / 2**30:.0f} GiB); "
                         f"run at most {MAX_LOG_BYTES / (n_sig * 8) * dt:.0f} s")
    return n_ticks


def run(loop: Loop, freq_hz: float, amp_n: float, duration_s: float, *, paced: bool = False,
        timing: bool = False, seed: int | None = None, chunk: int = 21000, progress=None,
        start: LoopState | None = None, writer=None, faults: np.ndarray | None = None,
        ring_ticks: int | None = None, in_thread: bool = True, controller=None) -> Run:
    """Run the closed loop for duration_s [s] with a sine excitation amp_n sin(2 pi freq_hz t).

    The run starts at rest (``initial_loop_state``) or from ``start`` (e.g. the ``final`` state
    of a previous run: a step-sine continues from the previous frequency's state; that start
    is not modified). Ticks continue from the start's tick k (t = k dt), so a run split in two
    at the same frequency equals one run, bit for bit.

    ``faults``: a fault schedule (``frictionrt.rt.loop.faults.schedule``; ticks absolute, so a split run takes
    the same schedule), none by default.

    ``writer`` (an ``frictionrt.rt.log.writer.LogWriter``) drains the log to files while the loop runs: its
    ``start(log, clk, k0, paced, digest, ticks)`` (ticks: the run's length) is called before the first tick, its ``finish()`` (write the
    rest, close the files) after the last one, also on an error or Ctrl-C.

    The log: without a writer and ``ring_ticks``, one row per tick of the run. With a writer
    (its ``ring_ticks`` rows) or ``ring_ticks``, a ring of R rows: tick k goes to row
    (k - k_start) mod R, offline the loop waits for the writer rather than overwrite a row it
    has not taken (none: nobody drains, the loop overwrites), paced it never waits (the writer
    drops what was overwritten). ``Run.log`` then holds the last min(ticks, R) ticks in tick
    order, ``Run.ticks`` the count, ``Run.digest`` the writer's whole-run figures (``summary``).

    ``controller``: another controller for stages 2-4, a callable taking ``_run_ticks``' arguments
    without force_col, observe and comp_ns (rt/export/sil.py: the C export), which starts from the
    controller states in est, law, sup, trk and leaves its own there, so that ``Run.final`` is the
    same as with the numba controller; not with ``timing``.

    ``in_thread``: the compiled loop runs in a thread of its own while the calling thread shows
    progress and turns Ctrl-C into a stop request (the ticks run so far are kept). False: in the
    calling thread, without progress, writer or pacing, and Ctrl-C raises KeyboardInterrupt once
    the current chunk has run; for a step-sine's blocks of a few thousand ticks, which would
    otherwise each start a thread (the same ticks, bit for bit).

    Raises ValueError for an excitation above Nyquist, a negative amplitude or duration, a log
    without a ring that would not fit in memory, or in_thread=False with progress, a writer or
    pacing; RuntimeError if a plant step failed.
    """
    cfg = loop.cfg
    dt = cfg.dt_s
    if writer is not None:
        ring_ticks = writer.ring_ticks
    if ring_ticks is not None and ring_ticks < 1:
        raise ValueError(f"ring_ticks {ring_ticks}: must be >= 1")
    if controller is not None and timing:
        raise ValueError("a controller of its own runs without per-component timing")
    if not in_thread and (paced or writer is not None or progress is not None):
        raise ValueError("in_thread=False runs without progress, writer or pacing: give none of them")
    n_ticks = check_run_input(loop, freq_hz, amp_n, duration_s, ring=ring_ticks is not None)
    n_rows = n_ticks if ring_ticks is None else min(n_ticks, int(ring_ticks))
    n_sig = len(loop.signals)
    seed = cfg.rt.seed if seed is None else seed
    plant = loop.plant
    oi = plant.output_index()
    ai = actuator_output_index()
    st = initial_loop_state(loop, seed) if start is None else start.copy()
    log = realtime.prefaulted((n_rows, n_sig))   # no page fault inside the loop
    comp_ns = realtime.prefaulted((n_rows, len(COMPONENTS)), np.int64) if timing else np.zeros((1, 1), np.int64)
    period_ns = int(round(dt * 1e9))
    clk = np.zeros(CLK_SIZE, dtype=np.int64)
    clk[CLK_WRITTEN] = st.k if writer is not None and not paced else NO_WAIT
    si = sensor_output_index()
    exc_point = cfg.plant.excitation_point
    force_col = si["F_strain" if loop.force_sensor == "strain" else "F_cell"]
    faults = no_faults() if faults is None else np.ascontiguousarray(faults, dtype=np.float64)
    exc = (dt, amp_n, 2 * math.pi * freq_hz)
    cols = (oi["u_rel"], oi["v_rel"], oi["abar_tip"], oi["abar_frf"], ai["F_strain_a"], ai["F_cell_a"], oi["dF_N1"],
            oi[f"w_{exc_point}"], oi[f"v_{exc_point}"])
    kf = _keyframe_ring(loop, st, writer, n_rows)
    failed = [0]
    t_first = [0]  # paced: the clock [ns] one period before the first deadline
    errors: list[BaseException] = []

    def worker():
        try:
            if paced:
                rts.enter_loop_thread()
            _chunks()
        except BaseException as err:  # re-raised in the calling thread
            errors.append(err)

    def _chunks():
        # paced: one compiled call for the whole run (Python between chunks would overrun);
        # a ring: chunks of whole rings, so that tick k lands in row (k - st.k) mod n_rows
        step = n_ticks if paced else (chunk if n_rows == n_ticks else max(1, chunk // n_rows) * n_rows)
        k = 0  # ticks run; tick st.k + k
        while k < n_ticks and not clk[CLK_STOP]:
            k1 = min(n_ticks, k + step)
            rows = slice(k, k1) if n_rows == n_ticks else slice(None)
            # the stages' tuples (``_run_ticks``): states of st advanced in place, fresh scratch per chunk
            sens = (st.xs, np.empty_like(st.xs), st.ys, np.empty_like(st.ys), np.empty_like(st.ys), np.zeros(5),
                    loop.sensors, st.rng)
            est, law, sup, trk = controller_stages(loop, st)
            act = (st.xa, np.empty_like(st.xa), st.ya, np.zeros(1), loop.actuator)
            plnt = (st.xp, np.empty_like(st.xp), st.yp, np.zeros(2), plant.params, st.plant_work)
            shk = (cfg.shaker.on, st.xsh, np.empty_like(st.xsh), np.zeros(3), np.zeros(1), loop.shaker)
            pace = (timing, paced, period_ns, rts.margin_ns, clk, ts)
            if paced and k == 0:  # the first deadline once this thread is ready to run (its start-up is no lateness)
                clk[CLK_DEADLINE] = _now_ns(ts) + START_SLACK_NS
                t_first[0] = clk[CLK_DEADLINE] - period_ns
            if controller is not None:
                failed[0] += controller(st.k + k, st.k + k1, exc, pace, faults, sens, est, law, sup, trk, act, plnt,
                                        shk, cols, log[rows], kf)
            else:
                failed[0] += _run_ticks(st.k + k, st.k + k1, exc, pace, force_col, loop.observes, faults,
                                        sens, est, law, sup, trk, act, plnt, shk, cols,
                                        log[rows], comp_ns[rows] if timing else comp_ns, kf)
            k = k1

    # the compiled loop holds no GIL (nogil): it runs in its own thread while this one shows
    # progress and turns Ctrl-C into a stop request; the ticks run so far are kept. Paced: the
    # real-time set-up around it (rt/loop/realtime.py), entered before the writer's thread starts
    ts = np.zeros(2, dtype=np.int64)
    with realtime.session(cfg.rt, paced) as rts:
        t_wall = _now_ns(ts)
        clk[CLK_DEADLINE] = t_wall + period_ns
        digest = None
        if writer is not None:
            from frictionrt.rt.loop.digest import RunDigest
            digest = RunDigest(loop.signals)
            writer.start(log, clk, st.k, paced, digest, n_ticks, keyframes=kf[:3])
        interrupted = False
        try:
            if in_thread:
                interrupted = watch(worker, "frictionrt-loop", clk, progress)
            else:
                worker()
        finally:
            if writer is not None:
                writer.finish()
    if errors:
        raise errors[0]
    n_run = int(clk[CLK_TICKS])
    st.k += n_run
    log = _in_tick_order(log, n_run)
    comp_ns = _in_tick_order(comp_ns, n_run) if timing else comp_ns
    wall = _now_ns(np.zeros(2, dtype=np.int64)) - (t_first[0] if paced and t_first[0] else t_wall)
    if writer is not None and writer.error is not None:
        raise RuntimeError(f"the log writer failed: {writer.error!r}") from writer.error
    if failed[0]:
        raise RuntimeError(f"the plant's contact solve failed in {failed[0]} of {n_run} ticks; "
                           "raise plant.substeps (e.g. --set plant.substeps=2) or plant.fallback_split")
    finite = np.isfinite(log)
    if not (finite.all() or np.all(finite | _dropout_mask(loop, faults, st.k - len(log), len(log)))):
        raise RuntimeError("the loop produced NaN/Inf: check the configuration and the excitation")
    return Run(loop, freq_hz, amp_n, log, comp_ns if timing else None, int(clk[CLK_OVERRUNS]), paced, int(wall),
               interrupted, st, faults, n_run, digest if len(log) < n_run else None,
               rts.describe() if paced else None)


def _keyframe_ring(loop: Loop, st: LoopState, writer, n_rows: int) -> tuple:
    """The key-frame argument of ``_run_ticks`` (``frictionrt.rt.loop.keyframe``) for a run of ``st``
    (its parts: views of its arrays) with ``writer``: a prefaulted ring beside the log's n_rows
    when the writer's MCAP file has a key-frame channel, else none (interval 0). ValueError if
    that channel's layout is not this loop's."""
    parts = keyframe_parts(st, loop.cfg.rt.keyframe_plant_cache)
    codec = getattr(getattr(writer, "mcap", None), "keyframes", None)
    if codec is None:
        return no_keyframes(parts)
    if [tuple(p.values()) for p in layout(parts)] != [tuple(p) for p in codec.parts]:
        raise ValueError("the log's key-frame layout is not this loop's state (keyframe_codec of another loop)")
    nf, ni = widths(parts)
    rows = ring_rows(n_rows, codec.interval)
    return (codec.interval, realtime.prefaulted((rows, nf)), realtime.prefaulted((rows, ni), np.int64), *views(parts))


def watch(target, name: str, clk: np.ndarray, progress=None) -> bool:
    """Run ``target`` (a compiled loop's call, nogil) in a thread named ``name`` and wait for it
    in the calling thread: every 0.1 s ``progress(n)`` with the ticks run since
    (``clk[CLK_TICKS]``), Ctrl-C as a stop request (``clk[CLK_STOP]``: the loop ends after its
    tick, the ticks run so far are kept). On any other exception here the loop is stopped and
    waited for before it propagates, so its rows are final. Returns True if interrupted. The
    loop (``run``), the replay and the null loop share it.

    The end of ``target`` is an Event the thread sets, not ``Thread.join``/``is_alive``: on
    CPython 3.11 (cpython#90882, reported for 3.9-3.11) a join interrupted by Ctrl-C can mark a
    still-running thread as stopped, and the log writer would then take the ticks before the
    loop's last one as final (seen: a paced run's log one tick short)."""
    done = threading.Event()

    def body():
        try:
            target()
        finally:
            done.set()

    shown, interrupted = 0, False
    thread = threading.Thread(target=body, name=name, daemon=True)
    try:
        thread.start()
    except KeyboardInterrupt:  # in start's wait for the new thread, which then runs: stop it
        clk[CLK_STOP] = 1
        interrupted = True
    try:
        while not done.is_set():
            try:
                done.wait(0.1)
            except KeyboardInterrupt:
                clk[CLK_STOP] = 1
                interrupted = True
            if progress is not None:
                ticks = int(clk[CLK_TICKS])
                progress(ticks - shown)
                shown = ticks
    finally:
        if not done.is_set():
            clk[CLK_STOP] = 1
        interrupted |= _wait_absorbing_ctrl_c(done, thread)
    return interrupted


def _wait_absorbing_ctrl_c(done: threading.Event, thread: threading.Thread) -> bool:
    """Wait for ``done`` (a stopped loop's end: within a tick), then for ``thread`` to return;
    a Ctrl-C does not cut the wait short. True if one came."""
    ctrl_c = False
    while not done.is_set():
        try:
            done.wait(0.1)
        except KeyboardInterrupt:
            ctrl_c = True
    try:
        thread.join()   # done: it only returns
    except KeyboardInterrupt:
        ctrl_c = True
    return ctrl_c


def _in_tick_order(ring: np.ndarray, n_run: int) -> np.ndarray:
    """The last min(n_run, len(ring)) ticks of a log whose tick i (from the run's start) is in
    row i mod len(ring), oldest first (a view when they are in order already)."""
    if n_run <= len(ring):
        return ring[:n_run]
    i0 = n_run % len(ring)
    return ring if i0 == 0 else np.concatenate((ring[i0:], ring[:i0]))


def _dropout_mask(loop: Loop, faults: np.ndarray, k0: int, n: int) -> np.ndarray:
    """True where an injected sensor_dropout makes a logged reading NaN (rows k0 .. k0 + n - 1)."""
    mask = np.zeros((n, len(loop.signals)), dtype=bool)
    for f in faults:
        if int(f[F_KIND]) == K_DROPOUT:
            lo, hi = max(int(f[F_START]) - k0, 0), min(int(min(f[F_END], 2**62)) - k0, n)
            if lo < hi:
                mask[lo:hi, 1 + int(f[F_TARGET])] = True  # column 0 is F_exc, then SENSOR_OUTPUTS
    return mask
