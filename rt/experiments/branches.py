"""Parallel: a (configuration, law, amplitude, frequency list) branch (``Branch``) is a pure function
of its parameters; ``run_branches`` runs branches in loky processes (a pool of its own)
or on a dask cluster, with one progress bar over the completed points, follow-up branches that
depend on a result as soon as it is in, and ``sweep_timing``, what the sweeps cost against
their ticks (docs/experiments.md, "Where the time goes"). The loops are designed once in the calling
process and shipped to the workers: the design (eigen decompositions, control design) goes
through BLAS/LAPACK, whose round-off depends on the thread count (loky and dask workers run one
BLAS thread); designed in each worker, the plant's modal data differed in the last bits and a
resonance point's H by 7 %. The compiled loop itself is deterministic, so the same configuration
and seed give bit-identical results sequentially, in local processes and on dask (tested).
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

from frictionrt.rt.common.config import Config, Estimator, dumps
from frictionrt.rt.experiments.stepsine import Settle, StepSineResult, check_sweep, slow_sweep, sweep
from frictionrt.rt.loop import Designs, Loop, build_loop
from frictionrt.rt.loop.structure import Structure

PROGRESS_TOPIC = "frictionrt-frf-point"  # dask event topic: one message per finished point


@dataclass(frozen=True)
class Branch:
    """One sweep: everything its result depends on (a pure function of these). A step-sine over
    freqs_hz, or with sweep_rate_hz_s a slow continuous sweep from freqs_hz[0] to freqs_hz[-1]."""
    cfg: Config
    law: str
    amp_n: float
    freqs_hz: tuple[float, ...]
    estimator: str = Estimator.ORACLE   # the laws' estimate (an Estimator); the rig's passive sweeps use the oracle
    settle: Settle = Settle()
    seed: int | None = None  # None: cfg.rt.seed
    sweep_rate_hz_s: float | None = None   # [Hz/s], signed by the direction of freqs_hz
    sweep_block_s: float = 0.1             # nominal dwell per point of a slow sweep [s]
    controller: object = None              # the loop's controller (run(..., controller=); None: numba), picklable:
    #                                        e.g. rt.export.sil.CController, which a worker loads by its library's path
    structure: Structure | None = None     # an imported structure as the plant (rt.loop.structure); None: the beams

    def n_points(self) -> int:
        """Frequency points it will measure (a slow sweep's: about |range| / (|rate| block))."""
        if self.sweep_rate_hz_s is None:
            return len(self.freqs_hz)
        return max(1, round(abs(self.freqs_hz[-1] - self.freqs_hz[0]) / (abs(self.sweep_rate_hz_s) * self.sweep_block_s)))


def run_branch(branch: Branch, loop: Loop | None = None,
               progress: Callable[[int], object] | None = None) -> StepSineResult:
    """One branch, from rest; loop: the branch's built loop (None: built here).

    BLAS runs one thread meanwhile, as in a loky worker: the harmonic fits' least squares
    (n x 11, n up to 3 x 6300 samples) took 71 ms each with two OpenBLAS threads on a loaded
    2-core machine against 1.7 ms with one, more than the ticks they analyse (the bits are the
    same: tests/test_stepsine.py compares a sequential run with worker processes)."""
    from threadpoolctl import threadpool_limits
    if loop is None:
        check_sweep(branch.cfg, branch.law, branch.freqs_hz, branch.amp_n, branch.settle, branch.estimator)
        loop = build_loop(branch.cfg, branch.law, branch.estimator, structure=branch.structure)
    with threadpool_limits(1):
        if branch.sweep_rate_hz_s is not None:
            return slow_sweep(loop, branch.freqs_hz[0], branch.freqs_hz[-1], branch.amp_n, branch.sweep_rate_hz_s,
                              block_s=branch.sweep_block_s, settle=branch.settle, seed=branch.seed,
                              progress=progress, controller=branch.controller)
        return sweep(loop, branch.freqs_hz, branch.amp_n, settle=branch.settle, seed=branch.seed, progress=progress,
                     controller=branch.controller)


def build_loops(branches: Sequence[Branch], designs: Designs | None = None) -> list[Loop]:
    """The loop of each branch, built once per distinct (configuration, law, estimator, structure),
    the plants and force-tracking designs shared (``designs``, None: a fresh ``Designs``)."""
    designs = Designs() if designs is None else designs
    built: dict[tuple, Loop] = {}
    for b in branches:
        key = (dumps(b.cfg), b.law, b.estimator, b.structure)
        if key not in built:
            built[key] = build_loop(b.cfg, b.law, b.estimator, designs=designs, structure=b.structure)
    return [built[(dumps(b.cfg), b.law, b.estimator, b.structure)] for b in branches]


class _QueueReport:
    """Progress from a local worker process: one message per point into a manager queue."""
    def __init__(self, queue):
        self.queue = queue

    def __call__(self, n: int) -> None:
        self.queue.put(n)


class _DaskReport:
    """Progress from a dask worker: one event per point, to the client's topic subscription."""
    def __call__(self, n: int) -> None:
        from distributed import get_worker
        get_worker().log_event(PROGRESS_TOPIC, n)


class Results(list):
    """``run_branches``' results, in branch order (a list), and ``cores``: the local worker
    processes or dask worker threads that ran them (1: this process). ``errors``: branch index ->
    the message of its numerical failure (``run_branches(keep_failed=True)``; that result is None)."""
    cores: int = 1
    errors: dict[int, str] = {}


def run_branches(branches: Sequence[Branch], jobs: int | None = None, dask_address: str | None = None, *,
                 progress: bool = True, connect_timeout_s: float = 5.0, loops: Sequence[Loop] | None = None,
                 desc: str = "step-sine", follow: Callable[[int, StepSineResult], Sequence[tuple[Branch, Loop]]]
                 | None = None, keep_failed: bool = False) -> Results:
    """Run the branches in parallel; results in the order of ``branches``, identical whichever
    backend (each branch is a pure function of its parameters, run on the same CPU model).

    jobs: local (loky) processes, default the number of cores (joblib.cpu_count(), capped at the
    number of branches; 1 runs in this process). dask_address (e.g. "tcp://host:8786"): run on that dask
    cluster instead (frictionrt must be installed on its workers; jobs is ignored, the cluster's
    worker threads decide). progress: a tqdm bar over the finished frequency points (stderr),
    labelled desc. loops: the branches' built loops, one per branch (None: built here by
    ``build_loops``; a caller running several studies builds them once).

    follow(i, result): called in this process as branch i finishes; the (branch, loop) pairs it
    returns (a refinement that depends on that result) run as soon as a worker is free, before
    the branches not yet started, their results appended in the order returned. keep_failed: a
    branch whose run fails numerically (RuntimeError, e.g. a contact solve that did not converge)
    gets None as its result and its message in ``Results.errors`` instead of ending the study
    (a tuning grid's candidate that its plant cannot follow). Scheduling
    (``_schedule``): two branches per worker in flight, the longest first (``expected_ticks``),
    so that no worker idles at a round's end while another finishes a long sweep.

    Raises ValueError for a bad branch (before anything runs; a follow-up's before it runs), jobs < 1
    or a loops list of another length, ConnectionError if no dask scheduler answers at
    dask_address within connect_timeout_s [s]."""
    import joblib
    from tqdm import tqdm

    for b in branches:
        check_sweep(b.cfg, b.law, b.freqs_hz, b.amp_n, b.settle, b.estimator)
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs {jobs}: must be >= 1 (default: the number of cores, {joblib.cpu_count()})")
    if loops is not None and len(loops) != len(branches):
        raise ValueError(f"{len(loops)} loops for {len(branches)} branches: give one loop per branch")
    client = connect(dask_address, connect_timeout_s) if dask_address is not None else None
    with tqdm(total=sum(b.n_points() for b in branches), unit="point", desc=desc, disable=not progress) as bar:
        todo = list(zip(branches, build_loops(branches) if loops is None else loops))
        if client is not None:
            with client:
                results = _run_dask(todo, client, bar, follow, keep_failed)
        else:
            results = _run_local(todo, min(jobs or joblib.cpu_count(), max(len(branches), 1)), bar, follow,
                                 keep_failed)
        bar.update(bar.total - bar.n)
    return results


def sweep_timing(results: Iterable[StepSineResult], wall_s: float, cores: int) -> dict:
    """What a study's sweeps cost against what their ticks cost: simulated_s [s] and ticks
    (the points' own, k_end - k_start), wall_s [s] (given: the study's, its design and worker
    start-up included), tick_s [s] (the ticks' execution times summed, the log's tick_ns:
    ``Point.tick_s``), cores (that ran the sweeps), tick_bound_s = tick_s / cores [s] (the
    study's wall time if nothing but the ticks took time) and ratio = wall_s / tick_bound_s [-]."""
    results = list(results)
    tick_s = float(sum(r.tick_s.sum() for r in results))
    bound = tick_s / cores
    return {"simulated_s": float(sum(r.settle_s.sum() for r in results)),
            "ticks": int(sum((r.k_end - r.k_start).sum() for r in results)), "wall_s": float(wall_s),
            "tick_s": tick_s, "cores": int(cores), "tick_bound_s": bound,
            "ratio": float(wall_s / bound) if bound > 0 else float("nan")}


def sweeps_line(t: dict) -> str:
    """``sweep_timing``'s figures in one line."""
    return (f"sweeps: {t['simulated_s']:.1f} s simulated ({t['ticks']:,} ticks) in {t['wall_s']:.1f} s wall on "
            f"{t['cores']} cores; the ticks' own {t['tick_s']:.1f} s, tick-bound {t['tick_bound_s']:.1f} s: "
            f"ratio {t['ratio']:.2f}")


def expected_ticks(branch: Branch) -> int:
    """The fewest ticks a branch can take [ticks]: 2 N blocks per point (``Settle``), a slow
    sweep's whole range at its rate; the scheduler's estimate of its length."""
    dt = branch.cfg.dt_s
    if branch.sweep_rate_hz_s is not None:
        return round(abs(branch.freqs_hz[-1] - branch.freqs_hz[0]) / abs(branch.sweep_rate_hz_s) / dt)
    return sum(2 * branch.settle.n_blocks * branch.settle.block_ticks(f, dt) for f in branch.freqs_hz)


def _schedule(todo: list, cores: int, submit, first_done, bar, follow, keep_failed: bool = False) -> Results:
    """Run todo [(branch, loop)] on ``cores`` workers through submit(branch, loop) -> future and
    first_done(futures) -> the finished ones; follow-ups (``run_branches``) first, then the rest
    longest first. Two branches per worker in flight, so that a worker finds its next branch
    queued when one ends (one in flight left each worker idle ~20 ms per branch, the round trip
    on a loaded 2-core machine). Returns the results by index of todo (which follow-ups extend)."""
    slots = 1 if cores == 1 else 2 * cores
    waiting = sorted(range(len(todo)), key=lambda i: -expected_ticks(todo[i][0]))
    results: dict[int, StepSineResult] = {}
    errors: dict[int, str] = {}
    running: dict = {}
    while waiting or running:
        while waiting and len(running) < slots:
            i = waiting.pop(0)
            running[submit(*todo[i])] = i
        for fut in first_done(list(running)):
            i = running.pop(fut)
            try:
                results[i] = fut.result()
            except RuntimeError as exc:
                if not keep_failed:
                    raise
                results[i], errors[i] = None, str(exc)
                continue
            more = list(follow(i, results[i])) if follow is not None else []
            for b, _ in more:
                check_sweep(b.cfg, b.law, b.freqs_hz, b.amp_n, b.settle, b.estimator)
                bar.total += b.n_points()
            waiting[:0] = range(len(todo), len(todo) + len(more))
            todo += more
    out = Results(results[i] for i in range(len(todo)))
    out.cores = cores
    out.errors = errors
    return out


def _run_local(todo, n_jobs: int, bar, follow, keep_failed: bool = False) -> Results:
    from concurrent.futures import FIRST_COMPLETED, Future, wait
    if n_jobs == 1:
        def submit(b, loop):
            fut = Future()
            try:
                fut.set_result(run_branch(b, loop, bar.update))
            except RuntimeError as exc:   # raised by fut.result(), as a worker's would be
                fut.set_exception(exc)
            return fut
        return _schedule(todo, 1, submit, lambda futs: futs, bar, follow, keep_failed)
    import multiprocessing

    import cloudpickle
    executor = start_workers(n_jobs)
    pickled: dict[int, bytes] = {}  # id(loop) -> the loop pickled once (5 ms each; unpickled in 0.4 ms)

    def submit(b, loop):
        if id(loop) not in pickled:
            pickled[id(loop)] = cloudpickle.dumps(loop)
        return executor.submit(_run_pickled, b, pickled[id(loop)], report)
    with multiprocessing.Manager() as manager:
        queue = manager.Queue()
        watcher = threading.Thread(target=_drain, args=(queue, bar), daemon=True)
        watcher.start()
        report = _QueueReport(queue)
        try:
            return _schedule(todo, n_jobs, submit, lambda futs: wait(futs, return_when=FIRST_COMPLETED).done,
                             bar, follow, keep_failed)
        finally:
            queue.put(None)
            watcher.join()


_POOL: dict = {}  # n_jobs -> this process's loky executor of the branches (``start_workers``)


def start_workers(n_jobs: int | None = None):
    """The local worker processes of the branches (a loky ProcessPoolExecutor of n_jobs, default
    the number of cores; kept for the process's next study), started now with the loop
    imported in each: a caller that designs loops first calls this before, so that the
    workers' start-up (~1.5 s each on 2 cores, mostly importing python-control and scipy)
    overlaps the design instead of delaying the first branch. ``run_branches`` with the same
    number of jobs reuses them. A pool of its own, not joblib's reusable executor, which
    ``joblib.Parallel`` (the diagnosis' fits) expects to have made itself."""
    import joblib
    from joblib.externals.loky import ProcessPoolExecutor
    n_jobs = n_jobs or joblib.cpu_count()
    if n_jobs not in _POOL:
        for old in _POOL.values():
            old.shutdown(wait=False)
        _POOL.clear()
        _POOL[n_jobs] = ProcessPoolExecutor(max_workers=n_jobs)
        for _ in range(n_jobs):
            _POOL[n_jobs].submit(_import_loop)
    return _POOL[n_jobs]


def _import_loop() -> None:
    """A worker's start-up: import what a branch runs (``start_workers``)."""
    import frictionrt.rt.loop.tick  # noqa: F401  (the compiled loop, loaded from numba's cache on its first call)


def _run_pickled(branch: Branch, loop: bytes, progress) -> StepSineResult:
    """``run_branch`` on a loop pickled once by the caller (``_run_local``)."""
    import pickle
    return run_branch(branch, pickle.loads(loop), progress)


def _drain(queue, bar) -> None:
    """Progress messages into the bar until the None sentinel."""
    while (n := queue.get()) is not None:
        bar.update(n)


def connect(address: str, timeout_s: float = 5.0):
    """A distributed.Client of the dask scheduler at address (e.g. "tcp://host:8786");
    ConnectionError if none answers within timeout_s [s]."""
    from distributed import Client
    try:
        return Client(address, timeout=f"{timeout_s}s")
    except (OSError, ValueError) as exc:  # TimeoutError is an OSError
        raise ConnectionError(f"no dask scheduler answered within {timeout_s:g} s ({exc}); start one "
                              "(`dask scheduler`, then `dask worker ADDRESS`) or run locally") from None


def _run_dask(todo, client, bar, follow, keep_failed: bool = False) -> Results:
    from distributed import wait
    client.subscribe_topic(PROGRESS_TOPIC, lambda event: bar.update(event[1]))
    shipped: dict[int, object] = {}  # id(loop) -> its future on the cluster: each loop sent once

    def submit(b, loop):
        if id(loop) not in shipped:
            shipped[id(loop)] = client.scatter(loop)
        return client.submit(run_branch, b, shipped[id(loop)], _DaskReport(), pure=False)
    try:
        return _schedule(todo, max(1, sum(client.nthreads().values())), submit,
                         lambda futs: wait(futs, return_when="FIRST_COMPLETED").done, bar, follow, keep_failed)
    finally:
        client.unsubscribe_topic(PROGRESS_TOPIC)
