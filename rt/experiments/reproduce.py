"""The paper's experiments in one run (SPEC section 6, ``frictionrt reproduce``): measurements and
the numbers the claims C1..C6 are decided on (rt.experiments.claims); report and figures: rt.experiments.reproduce_report.

What is measured (``measure``):

1. Impulse test (plant.impulse) at F_N1 = ``Plan.impulse_fn1_n`` (100 N, the paper's Fig. 5):
   FRF and identified modal damping ratios zeta of modes 2-5.
2. Bare structure (C1): the damping of the main beam without the damper. The plant cannot drop
   the damper (the configuration requires the damper beam held by its screws; with both screws
   open the damper beam floats free), so the bare structure's damping is the model's input
   ``plant.modal_damping`` (assumption A in SPEC 1, applied to every mode of each bare beam):
   C1 holds by construction here and the report says so; its eigenfrequencies are computed
   (plant.modes.bare_beam_bending_hz).
3. Step-sine FRFs (rt.experiments.stepsine, the excitation force amplitude held) around each mode of
   ``Plan.modes`` at each amplitude of ``Plan.amps_n`` for the passive law (F_N1 = F_passive =
   F_min), hysteresis-optimal and Lyapunov, and for the passive law at each constant F_N1 of
   ``Plan.fn1_n`` (the fair baseline: the best constant clamping force).

   Frequencies: ``Plan.n_points`` evenly over f_c (1 -/+ w_m) with f_c the middle of the mode's
   (f_slip, f_stuck) band (rt.experiments.stepsine.mode_bands_hz) and w_m = ``HALF_WIDTH[m]``: one grid per
   mode, the same for every law and F_N1. Then up to ``Plan.refine_rounds`` refinement rounds:
   a sweep whose largest |H| point has a neighbour more than ``RESOLVED_REL`` (10 %) below it,
   or whose 1/|H|^2 parabola through that point and its neighbours predicts a peak more than
   1 / (1 - RESOLVED_REL) above it, gets the midpoints toward them (``refine_points``), run as a new
   up-sweep from rest (the detector waits the start transient out); all FRFs in parallel, each
   FRF's next round as soon as its previous one is in.
   The peak is the largest measured |H| (``peak``); unsettled points count and are flagged.

Actuator power at a point: the energy over its measurement blocks (``StepSineResult.energy_j``)
divided by their duration, n_blocks x block length (rt.experiments.stepsine.Settle.block_ticks) [W].

The loops are designed once: the passive loop at another constant F_N1 differs only in the law's
F_passive (``loop_at_fn1``); the passive law ignores the estimate, so its loops use the oracle
and run once whatever ``estimators`` the controlled laws run on. The controlled laws run on each of
``estimators`` (default ``ESTIMATORS``: the paper's observer, then the oracle as the upper bound);
the claims of the first are the report's, every estimator's are side by side under "by_estimator".
"""
from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from frictionrt.rt.experiments.claims import claim_c1, claim_c2, claim_c3, claim_c4, claim_c5, claim_c6, peak_change_db
from frictionrt.rt.common.config import Config
from frictionrt.rt.common.config import ALL_ESTIMATORS, ESTIMATORS, Estimator
from frictionrt.rt.loop import Designs, Loop, build_loop
from frictionrt.rt.experiments.branches import Branch, run_branches, start_workers, sweep_timing
from frictionrt.rt.experiments.discretisation import (COARSENING, ORDER, STEP_ORDER, ErrorEstimate, annotate, coarser,
                                                      halved_step, margins, refined_impulse_margins, stored)
from frictionrt.rt.experiments.stepsine import Settle, StepSineResult, mode_bands_hz, resonance_grid

LAWS_COMPARED = ("passive", "hysteresis", "lyapunov")
# half width of each mode's grid, relative to its centre: modes 3 and 4 slide over a wide band
# (passive 20 N mode 3 below 190 Hz, stuck 223.6 Hz); modes 2 and 5 move less (passive peaks 68-69 Hz
# at 5-20 N, 608-610 Hz, against bands 71.1-73.8 and 609.2-616.5 Hz) and are sharp (zeta ~0.1-0.2 %)
HALF_WIDTH = {2: 0.08, 3: 0.15, 4: 0.12, 5: 0.04}
RESOLVED_REL = 0.10   # a peak is resolved when both neighbours lie within 10 % of it
BALANCE = 2.0        # a neighbour more than this many times as far from the largest point as the other: refine
MIN_STEP_REL = 2e-4   # no refinement below this spacing (relative): a jump is not a peak to chase
MECHANISM_S = 1.0     # simulated time of a failing cell's re-run [s] (explain_failures)


@dataclass(frozen=True)
class Plan:
    """What ``measure`` runs (SI units)."""
    modes: tuple[int, ...]          # bending modes (1 = first)
    amps_n: tuple[float, ...]       # excitation force amplitudes [N], >= 2 (C5 compares them)
    n_points: int                   # coarse grid points per mode
    refine_rounds: int              # refinement rounds at most
    fn1_n: tuple[float, ...]        # constant F_N1 [N] searched besides F_min (the passive law)
    settle: Settle                  # the step-sine detector
    impulse_fn1_n: float = 100.0    # F_N1 of the impulse test [N] (the paper's Fig. 5)

    def check(self, cfg: Config) -> None:
        """ValueError naming the bad value."""
        t = cfg.tracking
        if len(self.amps_n) < 2 or not all(math.isfinite(a) and a > 0 for a in self.amps_n):
            raise ValueError(f"amplitudes {self.amps_n}: give at least two finite amplitudes > 0 N")
        for f in self.fn1_n + (self.impulse_fn1_n,):
            if not t.F_min_N <= f <= t.F_max_N:
                raise ValueError(f"F_N1 {f:g} N lies outside [F_min, F_max] = [{t.F_min_N:g}, {t.F_max_N:g}] N")
        for m in self.modes:
            if m not in HALF_WIDTH:
                raise ValueError(f"mode {m}: the reproduction covers modes {sorted(HALF_WIDTH)}")


# --quick: modes 3 and 4, two amplitudes, a coarse grid, two refinements, two constant F_N1
QUICK = Plan(modes=(3, 4), amps_n=(5.0, 20.0), n_points=9, refine_rounds=2, fn1_n=(150.0, 600.0),
             settle=Settle(rel_tol=0.02, max_s=2.0))
# the full run: the paper's modes 2-5, three amplitudes, refinement to ~1/16 of the coarse step
FULL = Plan(modes=(2, 3, 4, 5), amps_n=(5.0, 10.0, 20.0), n_points=11, refine_rounds=4,
            fn1_n=(80.0, 160.0, 320.0, 600.0), settle=Settle(rel_tol=0.02, max_s=4.0))


class Key(tuple):
    """(law, fn1_n or None, mode, amp_n): one FRF. fn1_n None: the law as configured."""
    __slots__ = ()

    def __new__(cls, law: str, fn1_n: float | None, mode: int, amp_n: float):
        return super().__new__(cls, (law, fn1_n, mode, amp_n))

    law = property(lambda self: self[0])
    fn1_n = property(lambda self: self[1])
    mode = property(lambda self: self[2])
    amp_n = property(lambda self: self[3])


def mode_grids(cfg: Config, modes: Sequence[int], n_points: int,
               designs: Designs | None = None) -> dict[int, np.ndarray]:
    """mode -> coarse frequencies [Hz], increasing (module docstring); designs: the study's
    shared plant (``frictionrt.rt.loop.Designs``)."""
    bands = mode_bands_hz(cfg, modes, designs)
    return {m: resonance_grid([0.5 * (lo + hi)], HALF_WIDTH[m], n_points) for m, (lo, hi) in bands.items()}


def refine_points(freq_hz: np.ndarray, H_abs: np.ndarray, resolved_rel: float = RESOLVED_REL,
                  min_step_rel: float = MIN_STEP_REL) -> list[float]:
    """New frequencies [Hz] that resolve the peak of a measured |H| (freq_hz increasing), around
    the largest point i, each only where its step would exceed min_step_rel f_i. Empty: resolved.

    * the midpoint between i and each neighbour j with |H_j| < (1 - resolved_rel) |H_i|;
    * a peak narrower than the grid: near a resonance 1 / |H|^2 is a parabola in f (one mode:
      |H|^-2 ~ (f - f_0)^2 + b^2 within its half-power band b), so the parabola through i and its
      two neighbours predicts the peak 1 / sqrt(min) at its vertex f_0; if that is more than
      1 / (1 - resolved_rel) times |H_i|, the midpoint between i and the neighbour on f_0's side
      too. Without it two points of similar |H| on either flank of a sharp peak (mode 2: zeta ~0.1 %,
      half-power band 0.15 Hz against a 1.2 Hz grid) passed as resolved, 3.4 dB below it;
    * the midpoint toward a neighbour more than ``BALANCE`` (2) times as far from i as the other
      one: a friction-softened top is flat and lopsided, which the parabola does not see (mode 2,
      5 N at 120 N: 51.0 / 54.6 / 50.2 at 70.89 / 71.48 / 71.62 Hz passed both rules, the top is
      62.3 at 71.0 Hz)."""
    i = int(np.argmax(H_abs))
    new = set()
    for j in (i - 1, i + 1):
        if 0 <= j < len(freq_hz) and H_abs[j] < (1.0 - resolved_rel) * H_abs[i]:
            new.add(j)
    if 0 < i < len(freq_hz) - 1:
        f, y = freq_hz[i - 1:i + 2] - freq_hz[i], 1.0 / np.asarray(H_abs[i - 1:i + 2], dtype=float) ** 2
        c2, c1, c0 = np.polyfit(f, y, 2)
        if c2 > 0:
            f0, y0 = -c1 / (2 * c2), c0 - c1 * c1 / (4 * c2)
            if y0 <= 0 or 1.0 / math.sqrt(y0) > H_abs[i] / (1.0 - resolved_rel):
                new.add(i + 1 if f0 > 0 else i - 1)
        left, right = freq_hz[i] - freq_hz[i - 1], freq_hz[i + 1] - freq_hz[i]
        if left > BALANCE * right:
            new.add(i - 1)
        elif right > BALANCE * left:
            new.add(i + 1)
    return [0.5 * (freq_hz[i] + freq_hz[j]) for j in sorted(new)
            if abs(freq_hz[j] - freq_hz[i]) > min_step_rel * freq_hz[i]]


def merge(results: Sequence[StepSineResult]) -> StepSineResult:
    """The points of several sweeps of one (law, amplitude) as one result, by frequency."""
    first = results[0]
    cat = {f.name: np.concatenate([getattr(r, f.name) for r in results])
           for f in dataclasses.fields(StepSineResult) if isinstance(getattr(first, f.name), np.ndarray)}
    order = np.argsort(cat["freq_hz"], kind="stable")
    return dataclasses.replace(first, **{k: v[order] for k, v in cat.items()})


def measurement_s(r: StepSineResult, dt: float) -> np.ndarray:
    """Duration of each point's measurement blocks [s]: the final min(n_blocks, N) blocks."""
    n = np.minimum(r.n_blocks, r.settle.n_blocks)
    return np.array([k * r.settle.block_ticks(f, dt) * dt for k, f in zip(n, r.freq_hz)])


def point_power_w(r: StepSineResult, dt: float) -> np.ndarray:
    """Mean actuator power over each point's measurement blocks [W]: energy_j / measurement_s."""
    return r.energy_j / measurement_s(r, dt)


def peak(r: StepSineResult, dt: float) -> dict:
    """The largest measured |H| of an FRF: H_abs [(m/s^2)/N], f_hz, acc_m_s2 = |H| amp [m/s^2],
    settled, power_w there, at_band_edge (the largest point is the first or last: not a peak)."""
    i = int(np.argmax(r.H_abs))
    return {"H_abs": float(r.H_abs[i]), "f_hz": float(r.freq_hz[i]), "acc_m_s2": float(r.H_abs[i] * r.amp_n),
            "settled": bool(r.settled[i]), "power_w": float(point_power_w(r, dt)[i]),
            "F_N1_mean_n": float(r.F_N1_mean[i]), "at_band_edge": i in (0, len(r.freq_hz) - 1)}


def with_constant_fn1(cfg: Config, fn1_n: float) -> Config:
    """The configuration whose passive law holds F_N1 = fn1_n [N] (tracking.F_passive_N)."""
    return dataclasses.replace(cfg, tracking=dataclasses.replace(cfg.tracking, F_passive_N=float(fn1_n)))


def loop_at_fn1(passive: Loop, fn1_n: float) -> Loop:
    """A built passive loop at another constant F_N1 [N]: only the law's constants change."""
    from frictionrt.tracking.laws import build_laws
    cfg = with_constant_fn1(passive.cfg, fn1_n)
    return dataclasses.replace(passive, cfg=cfg, law_params=build_laws(cfg, "passive"))


def measure_frfs(cfg: Config, plan: Plan, estimators: Sequence[str] = ESTIMATORS, jobs: int | None = None,
                 dask_address: str | None = None, progress: bool = True,
                 designs: Designs | None = None) -> tuple[dict[str, dict[Key, StepSineResult]], list[StepSineResult], int]:
    """Every step-sine FRF of the plan (module docstring), refined, the controlled laws once per
    estimator of ``estimators``; (estimator -> Key -> merged result, every FRF once, the cores that
    ran the sweeps). The passive FRFs ignore the estimate: run once, in every estimator's view. An
    FRF's refinement round starts as soon as its previous round is in (``run_branches``' follow), so
    no core waits for the slowest FRF of a round."""
    estimators = tuple(dict.fromkeys(estimators))
    if dask_address is None and jobs != 1:
        start_workers(jobs)  # their start-up overlaps the design below
    designs = designs or Designs()  # one plant, one force-tracking design per sensor
    grids = mode_grids(cfg, plan.modes, plan.n_points, designs)
    # (law, F_N1, estimator) -> loop; estimator None: the passive law's, which ignores the estimate
    loops = {("passive", None, None): build_loop(cfg, "passive", Estimator.ORACLE, designs=designs)}
    for est in estimators:
        for law in LAWS_COMPARED[1:]:
            loops[(law, None, est)] = build_loop(cfg, law, est, designs=designs)
    for f in plan.fn1_n:
        loops[("passive", f, None)] = loop_at_fn1(loops[("passive", None, None)], f)
    runs = [(Key(law, f, m, a), est) for (law, f, est) in loops for m in plan.modes for a in plan.amps_n]
    parts: dict[tuple[Key, str | None], list[StepSineResult]] = {run: [] for run in runs}
    run_of: list[tuple[Key, str | None]] = []  # the FRF of each branch run, in run_branches' order

    def branch(run: tuple[Key, str | None], freqs) -> tuple[Branch, Loop]:
        run_of.append(run)
        k, est = run
        loop = loops[(k.law, k.fn1_n, est)]
        return Branch(loop.cfg, k.law, k.amp_n, tuple(float(x) for x in freqs), loop.estimator, plan.settle), loop

    def refine(i: int, r: StepSineResult) -> list[tuple[Branch, Loop]]:
        """The next round of run_of[i]'s FRF as soon as its last round is in (the rounds of
        one FRF follow each other; the FRFs do not wait for each other)."""
        run = run_of[i]
        parts[run].append(r)
        m = merge(parts[run])
        new = refine_points(m.freq_hz, m.H_abs) if len(parts[run]) <= plan.refine_rounds else []
        return [branch(run, new)] if new else []
    first = [branch(run, grids[run[0].mode]) for run in runs]
    results = run_branches([b for b, _ in first], jobs, dask_address, progress=progress,
                           loops=[loop for _, loop in first], desc="step-sine", follow=refine)
    merged = {run: merge(v) for run, v in parts.items()}
    views = {est: {k: r for (k, e), r in merged.items() if e in (None, est)} for est in estimators}
    return views, list(merged.values()), results.cores


def _table(frfs: dict[Key, StepSineResult], fn, laws=LAWS_COMPARED) -> dict:
    """law -> mode -> amplitude -> fn(result) over the laws' FRFs (fn1_n None)."""
    out: dict = {}
    for k, r in frfs.items():
        if k.fn1_n is None and k.law in laws:
            out.setdefault(k.law, {}).setdefault(k.mode, {})[k.amp_n] = fn(r)
    return out


def best_constant_fn1(cfg: Config, frfs: dict[Key, StepSineResult], peaks: dict) -> dict:
    """mode -> amplitude -> {fn1_n: the constant F_N1 [N] with the lowest peak |H| (F_min, the
    passive law, included), H_abs: that peak, peaks_by_fn1: F_N1 -> peak, and per controlled law
    {H_abs, vs_best_db = 20 log10(peak_law / best)}}."""
    out: dict = {}
    for k, r in frfs.items():
        if k.law == "passive":
            fn1 = cfg.tracking.F_passive_N if k.fn1_n is None else k.fn1_n
            d = out.setdefault(k.mode, {}).setdefault(k.amp_n, {"peaks_by_fn1": {}})
            d["peaks_by_fn1"][float(fn1)] = float(r.H_abs.max())
    for m, by_amp in out.items():
        for a, d in by_amp.items():
            fn1, best = min(d["peaks_by_fn1"].items(), key=lambda t: t[1])
            d |= {"fn1_n": fn1, "H_abs": best}
            for law in LAWS_COMPARED[1:]:
                p = peaks[law][m][a]["H_abs"]
                d[law] = {"H_abs": p, "vs_best_db": 20.0 * math.log10(p / best)}
    return out


def evaluate(cfg: Config, frfs: dict[Key, StepSineResult]) -> dict:
    """What one estimator's FRFs say (the passive ones among them): {peak_change_db, peaks,
    best_passive_fn1, energy, claims C3..C6} (C1, C2 rest on the impulse test: ``measure``)."""
    dt = cfg.dt_s
    peaks = _table(frfs, lambda r: peak(r, dt))
    reduction = peak_change_db(_table(frfs, lambda r: float(r.H_abs.max())))
    power = {law: {m: {a: p["power_w"] for a, p in by_amp.items()} for m, by_amp in by_mode.items()}
             for law, by_mode in peaks.items()}
    claims = {"C3": claim_c3(reduction), "C4": claim_c4(reduction), "C5": claim_c5(reduction),
              "C6": claim_c6(power) | {"note": "mean actuator power over the measurement blocks of each peak point"}}
    return {"claims": claims, "peak_change_db": reduction, "best_passive_fn1": best_constant_fn1(cfg, frfs, peaks),
            "peaks": peaks, "energy": {law: _energy(frfs, law, dt) for law in LAWS_COMPARED}}


def measure(cfg: Config, plan: Plan, estimators: Sequence[str] = ESTIMATORS, jobs: int | None = None,
            dask_address: str | None = None, progress: bool = True,
            stage: Callable[[str], object] | None = None,
            error_estimate: ErrorEstimate = ErrorEstimate.AUTO, explain: bool = True) -> dict:
    """Run the plan and evaluate the claims, the controlled laws on each of ``estimators``.
    Returns {"report": the JSON document, "frfs": Key -> StepSineResult of the first estimator,
    "frfs_by_estimator": estimator -> Key -> StepSineResult, "impulse": ImpulseResult}. The report
    holds claims, peak_change_db, best_passive_fn1, peaks and energy of the first estimator (the
    one the claims are decided on), the same per estimator under "by_estimator", and impulse,
    timing, plan, discretisation. Each claim carries its margin, the discretisation's estimated
    shift of it and its verdict (rt.experiments.discretisation; error_estimate: where the coarse
    and halved-step margins come from); explain: the measured mechanism of each cell that makes C3 or C4 fail
    (``explain_failures``) under "mechanisms". stage(text) is called before each stage."""
    from frictionrt.plant.impulse import impulse_test
    from frictionrt.plant.model import build_plant
    from frictionrt.plant.modes import bare_beam_bending_hz
    plan.check(cfg)
    estimators = tuple(dict.fromkeys(estimators))
    if not estimators or not set(estimators) <= set(ALL_ESTIMATORS):
        raise ValueError(f"estimators {list(estimators)}: give one or more of {', '.join(ALL_ESTIMATORS)}")
    say = stage or (lambda text: None)
    if dask_address is None and jobs != 1:
        start_workers(jobs)  # their start-up (imports) overlaps the impulse test and the designs
    t0 = time.perf_counter()
    say(f"impulse test at F_N1 = {plan.impulse_fn1_n:g} N")
    model = build_plant(cfg)
    imp = impulse_test(model, plan.impulse_fn1_n)
    zeta_passive = {m: float(z) for m, z in zip(imp.modes, imp.damping_ratio)}
    zeta_bare = {m: float(cfg.plant.modal_damping) for m in imp.modes}
    f_bare = bare_beam_bending_hz(model, cfg.plant.interface.lower)
    t_imp = time.perf_counter() - t0
    say(f"step-sine FRFs, the controlled laws on the {' and the '.join(estimators)}")
    designs = Designs()  # shared by the sweeps and the failing cells' re-runs
    views, every, cores = measure_frfs(cfg, plan, estimators, jobs, dask_address, progress, designs)
    t_frf = time.perf_counter() - t0 - t_imp
    impulse_claims = {
        "C1": claim_c1(zeta_bare) | {"note": "model input plant.modal_damping (assumption A), applied to "
                                             "every bare-beam mode: holds by construction, not measured"},
        "C2": claim_c2(zeta_passive, zeta_bare) | {"note": f"impulse test at F_N1 = {plan.impulse_fn1_n:g} N"}}
    by_est = {}
    for est, frfs in views.items():
        e = evaluate(cfg, frfs)
        by_est[est] = e | {"claims": impulse_claims | e["claims"]}
    error_estimate = ErrorEstimate(error_estimate)
    coarse = fine = half = None
    t_coarse = t_fine = t_half = 0.0
    if error_estimate is ErrorEstimate.AUTO:
        coarse, fine, half = stored(cfg, plan)
    source = "none" if error_estimate is ErrorEstimate.NONE else "stored"
    if fine is None and error_estimate is not ErrorEstimate.NONE:
        say(f"impulse test at F_N1 = {plan.impulse_fn1_n:g} N on the refined plant (pitch and elements / 2, "
            "substeps x 4)")
        t1 = time.perf_counter()
        fine = refined_impulse_margins(cfg, plan.impulse_fn1_n)
        t_fine = time.perf_counter() - t1
    if coarse is None and error_estimate is not ErrorEstimate.NONE:
        say(f"the same plan with the contact pitch and the elements x{COARSENING:g}: the discretisation's error")
        t1 = time.perf_counter()
        c = measure(coarser(cfg), plan, estimators, jobs, dask_address, progress, error_estimate=ErrorEstimate.NONE,
                    explain=False)
        coarse = {est: margins(v["claims"]) for est, v in c["report"]["by_estimator"].items()}
        t_coarse, source = time.perf_counter() - t1, "run"
    if half is None and error_estimate is not ErrorEstimate.NONE:
        say(f"the same plan with the plant's substeps x2 ({2 * cfg.plant.substeps}): the step's error")
        t1 = time.perf_counter()
        h = measure(halved_step(cfg), plan, estimators, jobs, dask_address, progress,
                    error_estimate=ErrorEstimate.NONE, explain=False)
        half = {est: margins(v["claims"]) for est, v in h["report"]["by_estimator"].items()}
        t_half, source = time.perf_counter() - t1, "run"
    for est in by_est:
        by_est[est]["claims"] = annotate(by_est[est]["claims"], None if coarse is None else coarse.get(est), source,
                                         fine, None if half is None else half.get(est))
    report = by_est[estimators[0]] | {
        "discretisation": {"source": source, "order": ORDER, "coarsening": COARSENING, "coarse_margins": coarse,
                           "step_order": STEP_ORDER, "half_step_margins": half,
                           "refined_margins": fine, "coarse_run_s": t_coarse, "half_step_run_s": t_half,
                           "refined_impulse_s": t_fine},
        "by_estimator": by_est,
        "impulse": {"fn1_n": plan.impulse_fn1_n, "modes": list(imp.modes),
                    "freq_hz": [float(f) for f in imp.freq_hz], "zeta": zeta_passive, "zeta_bare": zeta_bare,
                    "bare_beam_hz": [float(f) for f in f_bare]},
        "plan": {"modes": list(plan.modes), "amps_n": list(plan.amps_n), "n_points": plan.n_points,
                 "refine_rounds": plan.refine_rounds, "fn1_n": [cfg.tracking.F_passive_N, *plan.fn1_n],
                 "settle": dataclasses.asdict(plan.settle), "estimator": estimators[0],
                 "estimators": list(estimators),
                 "points": int(sum(len(r.freq_hz) for r in every)),
                 "unsettled": int(sum((~r.settled).sum() for r in every)),
                 "simulated_s": float(sum(r.settle_s.sum() for r in every))},
        "timing_s": {"impulse": t_imp, "step_sine": t_frf, "sweeps": sweep_timing(every, t_frf, cores)}}
    if explain:
        report["mechanisms"] = explain_failures(cfg, report, designs=designs)
    return {"report": report, "frfs": views[estimators[0]], "frfs_by_estimator": views, "impulse": imp}


def explain_failures(cfg: Config, report: dict, duration_s: float = MECHANISM_S,
                     designs: Designs | None = None) -> list[dict]:
    """The measured mechanism (rt.experiments.mechanisms) of every cell that makes C3 or C4 fail on
    an estimator of the report: each such cell's law run once more at its peak for duration_s
    (designs: the study's shared plant and force-tracking designs)."""
    from frictionrt.rt.experiments.mechanisms import failing_cells, mechanism
    from frictionrt.rt.experiments.reproduce_report import jsonable
    text = jsonable({k: report[k] for k in ("by_estimator", "best_passive_fn1")})
    cells = failing_cells(text["by_estimator"])
    designs = designs or Designs()
    return [mechanism(cfg, designs, c, text, duration_s) for c in cells]


def _energy(frfs: dict[Key, StepSineResult], law: str, dt: float) -> dict:
    """Actuator energy of a law over the measurement blocks of all its points [J], their
    duration [s] and the mean power [W] (energy / duration)."""
    E = T = 0.0
    for k, r in frfs.items():
        if k.law == law and k.fn1_n is None:
            E += float(r.energy_j.sum())
            T += float(measurement_s(r, dt).sum())
    return {"energy_j": E, "duration_s": T, "mean_power_w": E / T if T > 0 else 0.0}
