"""Gain tuning: a grid of law, force-tracking and observer parameters scored on step-sine peaks.

A candidate is a set of ``--set`` overrides (e.g. tracking.K_f=5e7, tracking.T1_s=0.01) applied
to the base configuration. Each candidate's law runs a step-sine sweep (rt.experiments.stepsine) around each
chosen mode at each chosen force amplitude; the passive law (constant F_N1 = F_passive) runs the
same sweeps once as the reference. Two objectives per candidate:

    peak_change_db = mean over (mode, amplitude) of  20 log10( max_f |H_law| / max_f |H_passive| )  [dB]
                     (minimised: negative = the law's peak is lower than passive; the peak is the
                     largest |H| of the grid around the mode; the sign of ``reproduce``)
    power_w        = mean over the sweeps' points of the actuator energy during the measurement
                     blocks divided by their duration [W]   (minimised; SPEC C6: actuator power)

A candidate is Pareto-optimal if no other has a peak change at most as large and a power at most
as large, one of them strictly. The best candidate is the one with the most negative peak change
(among those with power_w <= max_power_w if given); its full configuration is written as TOML
that every frictionrt command accepts with --config.

Every sweep is a ``Branch`` and they all run through ``run_branches``: joblib processes locally,
a dask cluster with ``dask_address``; the same configuration gives the same numbers either way.
"""
from __future__ import annotations

import itertools
import json
import os
import tempfile
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from frictionrt.rt.common.config import DEFAULT_ESTIMATOR, Config, ConfigError, check_key, dumps, with_sets
from frictionrt.rt.experiments.branches import Branch, build_loops, run_branches, start_workers, sweep_timing
from frictionrt.rt.loop import Designs
from frictionrt.rt.experiments.stepsine import Settle, StepSineResult, mode_bands_hz, resonance_grid

TUNED_LAWS = ("hysteresis", "lyapunov")

# default grids: the law's own parameters around the SPEC defaults (K_f 2.5e7 N/m, T1 0.02 s,
# eps 0.01 m/s); force-tracking and observer parameters are tuned by giving their keys
DEFAULT_GRIDS: dict[str, dict[str, tuple[float, ...]]] = {
    "hysteresis": {"tracking.K_f": (6.25e6, 1.25e7, 2.5e7, 5e7, 1e8), "tracking.T1_s": (0.005, 0.02, 0.08)},
    "lyapunov": {"tracking.eps_m_s": (0.001, 0.003, 0.01, 0.03, 0.1)},
}


@dataclass(frozen=True)
class Candidate:
    """One point of the grid: its overrides, its configuration and (once run) its scores."""
    sets: tuple[str, ...]              # ("tracking.K_f=5e+07", ...)
    cfg: Config | None                 # None: refused (error says why)
    error: str = ""


@dataclass
class TuneResult:
    law: str
    modes: tuple[int, ...]
    amps_n: tuple[float, ...]
    keys: tuple[str, ...]                  # the swept keys, in grid order
    values: np.ndarray                     # (n_candidates, n_keys) swept values
    errors: list[str]                      # per candidate: "" or why it was refused
    passive_peak: np.ndarray               # (n_modes, n_amps) max |H| passive [(m/s^2)/N]
    peak: np.ndarray                       # (n_candidates, n_modes, n_amps) max |H| of the law
    peak_change_db: np.ndarray             # (n_candidates,) objective 1 [dB], negative = lower peak (NaN: refused)
    power_w: np.ndarray                    # (n_candidates,) objective 2 [W] (NaN: refused)
    pareto: np.ndarray                     # (n_candidates,) bool
    best: int                              # index of the best candidate (-1: none qualifies)
    best_cfg: Config | None
    timing: dict | None = None             # the sweeps' cost (rt.experiments.branches.sweep_timing; wall-clock)
    resolution: list[dict] | None = None   # per (mode, amplitude): the passive peak on the grid and refined
    warnings: list[str] | None = None      # where the grid does not resolve a peak, and the points that would
    structure: dict | None = None          # the imported structure the sweeps ran on (file, sha256, clusters); None: the beams

    @property
    def best_config(self) -> Config | None:
        """The best candidate's full configuration (None: none qualifies)."""
        return self.best_cfg

    def plot(self):
        """The Pareto plot (``plot_pareto``): a matplotlib Figure."""
        return plot_pareto(self)

    def rows(self) -> list[dict]:
        """One dict per candidate: the swept values, objectives, Pareto flag, error."""
        out = []
        for i in range(len(self.values)):
            row = {k: float(v) for k, v in zip(self.keys, self.values[i])}
            row.update(peak_change_db=_num(self.peak_change_db[i]), power_w=_num(self.power_w[i]),
                       pareto=bool(self.pareto[i]), best=i == self.best, error=self.errors[i])
            out.append(row)
        return out

    def best_on_edge(self) -> list[str]:
        """The swept keys (with more than one value) whose best value is the grid's smallest or
        largest: the optimum may lie beyond the grid, so extend it there."""
        if self.best < 0:
            return []
        v = self.values
        return [k for j, k in enumerate(self.keys)
                if v[:, j].min() < v[:, j].max() and v[self.best, j] in (v[:, j].min(), v[:, j].max())]

    def to_dict(self) -> dict:
        return {"law": self.law, "modes": list(self.modes), "amps_n": list(self.amps_n), "keys": list(self.keys),
                "candidates": self.rows(), "passive_peak": self.passive_peak.tolist(),
                "best": None if self.best < 0 else self.rows()[self.best], "best_on_edge": self.best_on_edge(),
                "resolution": self.resolution or [], "warnings": self.warnings or [], "timing": self.timing,
                "structure": self.structure}


def _num(v: float) -> float | None:
    return None if math.isnan(v) else float(v)


def parse_grid(specs: Sequence[str]) -> dict[str, tuple[float, ...]]:
    """``KEY=V1,V2,...`` strings -> {key: values}; raises ValueError naming the bad spec."""
    grid: dict[str, tuple[float, ...]] = {}
    for spec in specs:
        key, sep, text = spec.partition("=")
        key = key.strip()
        try:
            values = tuple(float(v) for v in text.split(","))
        except ValueError:
            values = ()
        if not sep or not key or not values or not all(math.isfinite(v) for v in values):
            raise ValueError(f"--grid {spec!r}: expected KEY=V1,V2,... with numbers, e.g. tracking.K_f=1e7,2.5e7,5e7")
        if key in grid:
            raise ValueError(f"--grid {key}: given twice; list all its values in one --grid")
        grid[key] = values
    return grid


def candidates(base: Config, grid: dict[str, tuple[float, ...]]) -> list[Candidate]:
    """The Cartesian product of the grid, each applied to base. A key that does not exist
    raises ConfigError (a typo must not silently sweep nothing); a value the configuration
    refuses (out of range) makes that candidate refused, with the reason."""
    if not grid:
        raise ValueError("empty grid: give at least one --grid KEY=V1,V2,...")
    keys = list(grid)
    for k in keys:
        check_key(base, k)  # an unknown key fails here, for all candidates
    out = []
    for combo in itertools.product(*(grid[k] for k in keys)):
        sets = tuple(f"{k}={v!r}" for k, v in zip(keys, combo))
        try:
            out.append(Candidate(sets, with_sets(base, sets)))
        except ConfigError as exc:
            out.append(Candidate(sets, None, str(exc)))
    return out


def mode_grid(cfg: Config, mode: int, points: int, half_width_rel: float,
              designs: Designs | None = None, structure=None) -> tuple[float, ...]:
    """The step-sine frequencies [Hz] around a mode: ``resonance_grid`` about the middle of
    its (f_slip, f_stuck) band (``mode_bands_hz``; designs: the study's shared plant; structure:
    an imported structure's, ``frictionrt.rt.loop.structure.Structure``)."""
    f_slip, f_stuck = mode_bands_hz(cfg, (mode,), designs, structure)[mode]
    return tuple(float(f) for f in resonance_grid([0.5 * (f_slip + f_stuck)], half_width_rel, points))


def mean_power_w(r: StepSineResult, dt: float) -> float:
    """Mean actuator power [W] over a sweep's measurement blocks: energy / measured duration."""
    T = np.array([r.settle.n_blocks * r.settle.block_ticks(f, dt) * dt for f in r.freq_hz])
    return float(np.mean(r.energy_j / T))


def pareto_front(change: np.ndarray, cost: np.ndarray) -> np.ndarray:
    """Boolean mask of the non-dominated points (both minimised: the peak change and the cost;
    NaN excluded)."""
    ok = np.isfinite(change) & np.isfinite(cost)
    front = np.zeros(len(change), bool)
    for i in np.nonzero(ok)[0]:
        dominated = ok & (change <= change[i]) & (cost <= cost[i]) & ((change < change[i]) | (cost < cost[i]))
        front[i] = not dominated.any()
    return front


def select_best(change: np.ndarray, cost: np.ndarray, max_cost: float | None = None) -> int:
    """Index of the lowest peak change among the finite points with cost <= max_cost (if given);
    on equal change the lower cost; -1 if none qualifies."""
    ok = np.isfinite(change) & np.isfinite(cost)
    if max_cost is not None:
        ok &= cost <= max_cost
    if not ok.any():
        return -1
    idx = np.nonzero(ok)[0]
    return int(idx[np.lexsort((cost[idx], change[idx]))[0]])


def tune(base: Config, law: str, grid: dict[str, tuple[float, ...]], modes: Sequence[int] = (3, 4),
         amps_n: Sequence[float] = (5.0,), *, points: int = 9, half_width_rel: float = 0.15,
         estimator: str = DEFAULT_ESTIMATOR, settle: Settle = Settle(), max_power_w: float | None = None,
         jobs: int | None = None, dask_address: str | None = None, progress: bool = True,
         structure=None) -> TuneResult:
    """Score every candidate of grid (module docstring) for law at modes x amps_n [N]; structure: an
    imported structure as the plant of every sweep (``frictionrt.rt.loop.structure.Structure``; its
    modes as ``stepsine.structure_mode_bands_hz`` counts them), None: the configured beams.

    Raises ValueError for a law that has no gains, an empty grid or bad modes/amplitudes/points
    (before anything runs), ConfigError for a grid key that does not exist."""
    if law not in TUNED_LAWS:
        raise ValueError(f"law {law!r}: tune one of {', '.join(TUNED_LAWS)} (passive has no gains)")
    if points < 3:
        raise ValueError(f"points {points}: need >= 3 frequencies per mode to find a peak")
    if not amps_n or not all(a > 0 and math.isfinite(a) for a in amps_n):
        raise ValueError(f"amplitudes {list(amps_n)}: give positive force amplitudes [N]")
    if max_power_w is not None and not max_power_w > 0:
        raise ValueError(f"max power {max_power_w}: must be > 0 W")
    modes, amps_n = tuple(modes), tuple(float(a) for a in amps_n)
    t0 = time.perf_counter()
    cands = candidates(base, grid)
    if dask_address is None and jobs != 1:
        start_workers(jobs)  # their start-up overlaps the design below
    designs = Designs()  # the candidates share the plant and, unless they change it, the force-tracking design
    freqs = {m: mode_grid(base, m, points, half_width_rel, designs, structure) for m in modes}  # raises for a bad mode
    cells = [(m, a) for m in modes for a in amps_n]
    ok = [c for c in cands if c.cfg is not None]
    branches = [Branch(base, "passive", a, freqs[m], estimator, settle, structure=structure) for m, a in cells]
    branches += [Branch(c.cfg, law, a, freqs[m], estimator, settle, structure=structure) for c in ok for m, a in cells]
    loops = build_loops(branches, designs)
    results = run_branches(branches, jobs, dask_address, progress=progress, loops=loops, keep_failed=True)
    for i in range(len(cells)):
        if i in results.errors:   # the reference itself failed: nothing to score against
            raise RuntimeError(f"the passive reference sweep failed: {results.errors[i]}")
    resolution = passive_resolution(branches[:len(cells)], loops[:len(cells)], results[:len(cells)], cells,
                                    half_width_rel, jobs, dask_address)
    timing = sweep_timing([r for r in results if r is not None], time.perf_counter() - t0, results.cores)
    shape = (len(modes), len(amps_n))
    passive_peak = np.array([r.H_abs.max() for r in results[:len(cells)]]).reshape(shape)
    n = len(cands)
    peak = np.full((n,) + shape, np.nan)
    power = np.full(n, np.nan)
    it = iter(range(len(cells), len(results)))
    for i, c in enumerate(cands):
        if c.cfg is None:
            continue
        idx = [next(it) for _ in cells]
        if failed := [results.errors[j] for j in idx if j in results.errors]:
            cands[i] = Candidate(c.sets, c.cfg, f"run failed: {failed[0]}")   # refused, scored NaN
            continue
        rs = [results[j] for j in idx]
        peak[i] = np.array([r.H_abs.max() for r in rs]).reshape(shape)
        power[i] = float(np.mean([mean_power_w(r, base.dt_s) for r in rs]))
    change = 20.0 * np.log10(peak / passive_peak[None]).reshape(n, -1).mean(axis=1)
    front = pareto_front(change, power)
    best = select_best(change, power, max_power_w)
    keys = tuple(grid)
    values = np.array([[float(s.split("=", 1)[1]) for s in c.sets] for c in cands])
    return TuneResult(law, modes, amps_n, keys, values, [c.error for c in cands], passive_peak, peak, change,
                      power, front, best, None if best < 0 else cands[best].cfg, timing, resolution,
                      [r["warning"] for r in resolution if r["warning"]],
                      None if structure is None else json.loads(structure.record()))


RESOLVED_DB = 1.0      # a grid resolves a peak when its highest point is within 1 dB of the refined peak
REFINE_ROUNDS = 8      # refinement rounds of the passive check (each halves the step toward the peak)


def points_for(half_width_hz: float, width_hz: float, half_width_rel: float, centre_hz: float,
               db: float = RESOLVED_DB) -> int:
    """Grid points over +/- ``half_width_rel`` of ``centre_hz`` [Hz] whose step puts a point within
    ``db`` of a single-mode peak of half-power half-width ``width_hz`` [Hz]: near the peak
    |H|^2 / |H_max|^2 = b^2 / ((f - f_0)^2 + b^2), the worst point lies half a step off, so the step
    is at most 2 b sqrt(10^(db/10) - 1)."""
    step = 2.0 * width_hz * math.sqrt(10.0 ** (db / 10.0) - 1.0)
    return int(math.ceil(2.0 * half_width_rel * centre_hz / step)) + 1


def passive_resolution(branches: Sequence[Branch], loops, results, cells, half_width_rel: float,
                       jobs: int | None = None, dask_address: str | None = None) -> list[dict]:
    """Whether each passive sweep's grid resolves its peak: the passive law's peak refined by
    ``REFINE_ROUNDS`` rounds of midpoints toward it (``reproduce.refine_points``, single points from
    rest) against the grid's highest point. Per cell: mode, amp_n, grid_peak, refined_peak
    [(m/s^2)/N], error_db (20 log10 grid / refined, <= 0), points_needed (``points_for``, from the
    parabola 1/|H|^2 through the refined peak's three points) and "warning" (empty when within
    ``RESOLVED_DB``)."""
    from dataclasses import replace

    from frictionrt.rt.experiments.reproduce import merge, refine_points
    merged = list(results)
    for _ in range(REFINE_ROUNDS):
        todo = [(i, f) for i, r in enumerate(merged) for f in refine_points(r.freq_hz, r.H_abs)]
        if not todo:
            break
        new = run_branches([replace(branches[i], freqs_hz=(f,)) for i, f in todo], jobs, dask_address,
                           progress=False, loops=[loops[i] for i, _ in todo])
        for (i, _), r in zip(todo, new):
            merged[i] = merge([merged[i], r])
    out = []
    for (mode, amp), b, grid, ref in zip(cells, branches, results, merged):
        g, p = float(grid.H_abs.max()), float(ref.H_abs.max())
        err = 20.0 * math.log10(g / p) if p > 0 else 0.0
        k = int(np.argmax(ref.H_abs))
        needed = None
        if 0 < k < len(ref.freq_hz) - 1:
            f, y = ref.freq_hz[k - 1:k + 2] - ref.freq_hz[k], 1.0 / ref.H_abs[k - 1:k + 2] ** 2
            c2, c1, c0 = np.polyfit(f, y, 2)
            y0 = c0 - c1 * c1 / (4 * c2) if c2 > 0 else 0.0
            if c2 > 0 and y0 > 0:
                centre = 0.5 * (b.freqs_hz[0] + b.freqs_hz[-1])
                needed = points_for(half_width_rel * centre, math.sqrt(y0 / c2), half_width_rel, centre)
        warn = ""
        if err < -RESOLVED_DB:
            warn = (f"mode {mode} at {amp:g} N: the grid of {len(grid.freq_hz)} points puts the passive peak at "
                    f"{g:.3g} (m/s^2)/N, {-err:.1f} dB below the refined {p:.3g}; the peak changes are not resolved"
                    + (f": use --points {needed} or more" if needed else ": use more --points"))
        out.append({"mode": mode, "amp_n": amp, "grid_peak": g, "refined_peak": p, "error_db": err,
                    "refined_f_hz": float(ref.freq_hz[k]), "points_needed": needed, "warning": warn})
    return out


def best_toml(res: TuneResult) -> str:
    """The best candidate's full configuration (``dumps``), headed by what was tuned and scored."""
    if res.best_cfg is None:
        raise ValueError("no candidate qualifies (all refused, or none within the power limit)")
    row = res.rows()[res.best]
    head = [f"# frictionrt tune --law {res.law}: best of {len(res.values)} candidates, modes {list(res.modes)}, "
            f"amplitudes {list(res.amps_n)} N",
            f"# {', '.join(f'{k} = {row[k]:g}' for k in res.keys)}: peak change {row['peak_change_db']:+.2f} dB "
            "(negative: lower than passive), "
            f"actuator power {row['power_w']:.3g} W"]
    if res.structure is not None:
        head.append(f"# on the imported structure {res.structure['file']} (--clusters {res.structure['clusters']} "
                    f"--clustering {res.structure.get('clustering', 'coordinates')}, SHA-256 "
                    f"{res.structure['sha256'][:12]}...): use it with --structure FILE --clusters N --clustering C")
    return "\n".join(head) + "\n" + dumps(res.best_cfg)


def plot_pareto(res: TuneResult, path: str | None = None):
    """Peak change [dB] (negative: lower than passive) against actuator power [W], the Pareto
    front joined, the best marked."""
    import matplotlib.ticker
    from matplotlib.figure import Figure
    fig = Figure(figsize=(7, 4.5))
    ax = fig.subplots()
    ok = np.isfinite(res.peak_change_db)
    ax.scatter(res.power_w[ok], res.peak_change_db[ok], c="0.6", s=18, label="candidate")
    f = np.nonzero(res.pareto)[0]
    f = f[np.argsort(res.power_w[f])]
    ax.plot(res.power_w[f], res.peak_change_db[f], "o-", c="C0", label="Pareto front")
    for i in f:
        ax.annotate(", ".join(f"{v:g}" for v in res.values[i]), (res.power_w[i], res.peak_change_db[i]),
                    fontsize=7, xytext=(3, 3), textcoords="offset points")
    if res.best >= 0:
        ax.plot(res.power_w[res.best], res.peak_change_db[res.best], "*", c="C3", ms=14, label="best")
    ax.axhline(0.0, c="k", lw=0.8, ls="--", label="passive")
    if np.all(res.power_w[ok] > 0):
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
    ax.set_xlabel("mean actuator power [W]")
    ax.set_ylabel("mean peak change vs passive [dB] (negative: lower)")
    ax.set_title(f"{res.law}: {', '.join(res.keys)}; modes {list(res.modes)}, {list(res.amps_n)} N")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig


def markdown_table(rows: list[dict], keys) -> str:
    head = list(keys) + ["peak change [dB] (negative: lower)", "power [W]", "Pareto", "best", "refused"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in rows:
        red = "" if r["peak_change_db"] is None else f"{r['peak_change_db']:+.2f}"
        pw = "" if r["power_w"] is None else f"{r['power_w']:.3g}"
        lines.append("| " + " | ".join([f"{r[k]:g}" for k in keys] + [red, pw, "yes" if r["pareto"] else "",
                                                                      "**best**" if r["best"] else "", r["error"]])
                     + " |")
    return "\n".join(lines) + "\n"


def csv_table(rows: list[dict], keys) -> str:
    import csv
    import io
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(list(keys) + ["peak_change_db", "power_w", "pareto", "best", "error"])
    for r in rows:
        w.writerow([r[k] for k in keys] + ["" if r["peak_change_db"] is None else r["peak_change_db"],
                                           "" if r["power_w"] is None else r["power_w"], r["pareto"], r["best"],
                                           r["error"]])
    return buf.getvalue()


def write_outputs(res, out: Path) -> None:
    """Write the files into a temporary folder beside out, then move them in (never half-written)."""
    out.mkdir(parents=True, exist_ok=True)
    rows = res.rows()
    with tempfile.TemporaryDirectory(dir=out, prefix=".tune-") as tmp:
        t = Path(tmp)
        (t / "table.csv").write_text(csv_table(rows, res.keys))
        (t / "table.md").write_text(markdown_table(rows, res.keys))
        (t / "tune.json").write_text(json.dumps(res.to_dict(), indent=1))
        plot_pareto(res, str(t / "pareto.png"))
        if res.best >= 0:
            (t / "best.toml").write_text(best_toml(res))
        for f in t.iterdir():
            os.replace(f, out / f.name)
    if res.best < 0 and (out / "best.toml").exists():
        (out / "best.toml").unlink()  # an older run's best must not pass for this one's
