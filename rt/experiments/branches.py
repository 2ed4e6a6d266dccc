"""Parallel: a (configuration, law, amplitude, frequency list) branch (``Branch``) is a pure function
of its parameters; ``run_branches`` runs branches in joblib (loky) processes or on a dask cluster,
with one progress bar over the completed points. The loops are designed once in the calling
process and shipped to the workers: the design (eigen decompositions, control design) goes
through BLAS/LAPACK, whose round-off depends on the thread count (loky and dask workers run one
BLAS thread); designed in each worker, the plant's modal data differed in the last bits and a
resonance point's H by 7 %. The compiled loop itself is deterministic, so the same configuration
and seed give bit-identical results sequentially, in local processes and on dask (tested).
"""
from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from rt.common.config import Config, dumps
from rt.experiments.stepsine import Settle, StepSineResult, check_sweep, slow_sweep, sweep
from rt.loop import Loop, build_loop

PROGRESS_TOPIC = "frictionrt-frf-point"  # dask event topic: one message per finished point


@dataclass(frozen=True)
class Branch:
    """One sweep: everything its result depends on (a pure function of these). A step-sine over
    freqs_hz, or with sweep_rate_hz_s a slow continuous sweep from freqs_hz[0] to freqs_hz[-1]."""
    cfg: Config
    law: str
    amp_n: float
    freqs_hz: tuple[float, ...]
    estimator: str = "oracle"
    settle: Settle = Settle()
    seed: int | None = None  # None: cfg.rt.seed
    sweep_rate_hz_s: float | None = None   # [Hz/s], signed by the direction of freqs_hz
    sweep_block_s: float = 0.1             # nominal dwell per point of a slow sweep [s]

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
        loop = build_loop(branch.cfg, branch.law, branch.estimator)
    with threadpool_limits(1):
        if branch.sweep_rate_hz_s is not None:
            return slow_sweep(loop, branch.freqs_hz[0], branch.freqs_hz[-1], branch.amp_n, branch.sweep_rate_hz_s,
                              block_s=branch.sweep_block_s, settle=branch.settle, seed=branch.seed,
                              progress=progress)
        return sweep(loop, branch.freqs_hz, branch.amp_n, settle=branch.settle, seed=branch.seed, progress=progress)


def build_loops(branches: Sequence[Branch]) -> list[Loop]:
    """The loop of each branch, built once per distinct (configuration, law, estimator)."""
    built: dict[tuple[str, str, str], Loop] = {}
    for b in branches:
        key = (dumps(b.cfg), b.law, b.estimator)
        if key not in built:
            built[key] = build_loop(b.cfg, b.law, b.estimator)
    return [built[(dumps(b.cfg), b.law, b.estimator)] for b in branches]


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


def run_branches(branches: Sequence[Branch], jobs: int | None = None, dask_address: str | None = None, *,
                 progress: bool = True, connect_timeout_s: float = 5.0, loops: Sequence[Loop] | None = None,
                 desc: str = "step-sine") -> list[StepSineResult]:
    """Run the branches in parallel; results in the order of ``branches``, identical whichever
    backend (each branch is a pure function of its parameters, run on the same CPU model).

    jobs: local joblib (loky) processes, default the number of cores (joblib.cpu_count(), capped at the
    number of branches; 1 runs in this process). dask_address (e.g. "tcp://host:8786"): run on that dask
    cluster instead (joblib's dask backend; frictionrt must be installed on its workers; jobs is
    ignored, the cluster's workers decide). progress: a tqdm bar over the finished frequency
    points (stderr), labelled desc. loops: the branches' built loops, one per branch (None: built
    here by ``build_loops``; a caller running several rounds of branches builds them once). Raises
    ValueError for a bad branch (before anything runs), jobs < 1 or a loops list of another length,
    ConnectionError if no dask scheduler answers at dask_address within connect_timeout_s [s]."""
    import joblib
    from tqdm import tqdm

    for b in branches:
        check_sweep(b.cfg, b.law, b.freqs_hz, b.amp_n, b.settle, b.estimator)
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs {jobs}: must be >= 1 (default: the number of cores, {joblib.cpu_count()})")
    if loops is not None and len(loops) != len(branches):
        raise ValueError(f"{len(loops)} loops for {len(branches)} branches: give one loop per branch")
    total = sum(b.n_points() for b in branches)
    client = _connect(dask_address, connect_timeout_s) if dask_address is not None else None
    with tqdm(total=total, unit="point", desc=desc, disable=not progress) as bar:
        loops = build_loops(branches) if loops is None else list(loops)
        if client is not None:
            with client:
                results = _run_dask(branches, loops, client, bar)
        else:
            n_jobs = min(jobs or joblib.cpu_count(), max(len(branches), 1))
            results = _run_local(branches, loops, n_jobs, bar)
        bar.update(total - bar.n)
    return results


def _run_local(branches, loops, n_jobs: int, bar) -> list[StepSineResult]:
    import joblib
    if n_jobs == 1:
        return [run_branch(b, loop, bar.update) for b, loop in zip(branches, loops)]
    import multiprocessing
    with multiprocessing.Manager() as manager:
        queue = manager.Queue()
        watcher = threading.Thread(target=_drain, args=(queue, bar), daemon=True)
        watcher.start()
        try:
            return joblib.Parallel(n_jobs=n_jobs, backend="loky")(
                joblib.delayed(run_branch)(b, loop, _QueueReport(queue)) for b, loop in zip(branches, loops))
        finally:
            queue.put(None)
            watcher.join()


def _drain(queue, bar) -> None:
    """Progress messages into the bar until the None sentinel."""
    while (n := queue.get()) is not None:
        bar.update(n)


def _connect(address: str, timeout_s: float):
    """A distributed.Client of the scheduler at address; ConnectionError if none answers."""
    from distributed import Client
    try:
        return Client(address, timeout=f"{timeout_s}s")
    except (OSError, ValueError) as exc:  # TimeoutError is an OSError
        raise ConnectionError(f"no dask scheduler answered within {timeout_s:g} s ({exc}); start one "
                              "(`dask scheduler`, then `dask worker ADDRESS`) or run locally") from None


def _run_dask(branches, loops, client, bar) -> list[StepSineResult]:
    import joblib
    client.subscribe_topic(PROGRESS_TOPIC, lambda event: bar.update(event[1]))
    try:
        with joblib.parallel_config(backend="dask"):
            return joblib.Parallel(n_jobs=-1)(joblib.delayed(run_branch)(b, loop, _DaskReport())
                                              for b, loop in zip(branches, loops))
    finally:
        client.unsubscribe_topic(PROGRESS_TOPIC)
