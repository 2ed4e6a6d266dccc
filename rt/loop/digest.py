"""Whole-run figures of a ring run, folded block by block as the writer takes rows out of the ring.

A run with a ring (``frictionrt.rt.loop.driver.run``) keeps only its last R ticks in memory, but ``frictionrt.rt.loop.results.summary``
reports some figures over the whole run. The writer (``frictionrt.rt.log.writer.LogWriter``) hands every block
it copies out of the ring to ``RunDigest.add``, which keeps, exactly and in memory independent of
the run's length (but for the number of distinct values and changes):

* ``ticks``, ``fn1_sum``: the count of ticks folded and the sum of F_N1 [N] (mean = sum / ticks;
  summed per block, so it may differ from numpy's pairwise mean of the whole column in the last
  bits);
* the distinct tick_ns values [ns] with their counts: the median (as ``np.median``: the mean of
  the two middle values for an even count) and the maximum are exact;
* the ticks where fault_latched, fault_code and passive change (each from 0 before the first
  tick): piecewise constant, so ``values_at`` gives them at any tick, and ``frictionrt.rt.loop.faults.trips``
  and ``frictionrt.rt.loop.faults.outcome`` evaluated on the change ticks (plus the faults' start ticks) give
  what they give on the whole columns.

Offline nothing is dropped, so the digest covers every tick; a paced writer that drops blocks
leaves them out (``ticks`` < the run's ticks).
"""
from __future__ import annotations

import numpy as np

STEP_SIGNALS = ("fault_latched", "fault_code", "passive")  # piecewise-constant columns kept as changes


class RunDigest:
    """Folds blocks of a run's log (columns in ``signals`` order, ``frictionrt.rt.loop.build.loop_signals``)."""

    def __init__(self, signals):
        names = [n for n, _, _ in signals]
        self._c_fn1, self._c_tick = names.index("F_N1"), names.index("tick_ns")
        self._c_step = [names.index(n) for n in STEP_SIGNALS]
        self.ticks = 0
        self.k_first = self.k_last = None   # first and last tick folded
        self.fn1_sum = 0.0
        self._tick_values = np.zeros(0)
        self._tick_counts = np.zeros(0, np.int64)
        self._last = np.zeros(len(STEP_SIGNALS))           # values before the next block
        self._changes: list[list[np.ndarray]] = [[] for _ in STEP_SIGNALS]  # (ticks, values) pairs

    def add(self, k0: int, block: np.ndarray) -> None:
        """Fold ticks k0 .. k0 + len(block) - 1 (blocks in increasing tick order)."""
        n = len(block)
        if n == 0:
            return
        self.ticks += n
        self.k_first = k0 if self.k_first is None else self.k_first
        self.k_last = k0 + n - 1
        self.fn1_sum += float(np.sum(block[:, self._c_fn1]))
        v, c = np.unique(block[:, self._c_tick], return_counts=True)
        v, inv = np.unique(np.concatenate((self._tick_values, v)), return_inverse=True)
        self._tick_counts = np.bincount(inv, np.concatenate((self._tick_counts, c)), len(v)).astype(np.int64)
        self._tick_values = v
        for j, col in enumerate(self._c_step):
            x = block[:, col]
            i = np.nonzero(np.diff(np.r_[self._last[j], x]) != 0)[0]
            if len(i):
                self._changes[j].append(np.stack((k0 + i, x[i])))
            self._last[j] = x[-1]

    def fn1_mean(self) -> float:
        """Mean F_N1 [N] over the ticks folded."""
        return self.fn1_sum / self.ticks

    def tick_median(self) -> float:
        """Median tick_ns [ns] over the ticks folded (``np.median``'s value)."""
        cum = np.cumsum(self._tick_counts)
        a = self._tick_values[np.searchsorted(cum, (self.ticks - 1) // 2, side="right")]
        b = self._tick_values[np.searchsorted(cum, self.ticks // 2, side="right")]
        return float((a + b) / 2)

    def tick_max(self) -> float:
        """Largest tick_ns [ns]."""
        return float(self._tick_values[-1])

    def change_ticks(self, extra=()) -> np.ndarray:
        """The first tick folded, every tick where one of ``STEP_SIGNALS`` changes, and the ticks
        ``extra`` that lie in the ticks folded (sorted, int64)."""
        parts = [p[0] for ch in self._changes for p in ch]
        k = np.concatenate([np.array([self.k_first], np.int64), np.asarray(extra, np.int64), *parts])
        return np.unique(k[(k >= self.k_first) & (k <= self.k_last)]).astype(np.int64)

    def values_at(self, name: str, k: np.ndarray) -> np.ndarray:
        """The step signal ``name`` (one of ``STEP_SIGNALS``) at the ticks k (0 before its first change)."""
        ch = self._changes[STEP_SIGNALS.index(name)]
        if not ch:
            return np.zeros(len(k))
        kc, vc = np.concatenate(ch, axis=1)
        i = np.searchsorted(kc, k, side="right") - 1
        return np.where(i >= 0, vc[np.maximum(i, 0)], 0.0)
