"""The jobs a user runs, as Python functions: ``import frictionrt as fr; fr.simulate(...)``.

Each job is the computation of one command of the ``frictionrt`` command line, with the same
defaults (the command line calls these functions, so the two cannot disagree), and returns a
``Result`` (``frictionrt.results``): ``.to_dict()`` is what ``--json`` prints, ``.plot()`` a
matplotlib Figure where the job has a picture. A configuration argument ``cfg`` of None means the
spec's defaults (``load_config()``). Quantities are SI: N, Hz, s, m.

Files are written only where a job is given ``out`` (the command line gives its default folders);
an existing output is refused unless ``force=True``. Bad input raises ``ValueError`` with one line
naming the value and the fix; a configuration that cannot be built raises ``ConfigError`` (a
``ValueError``).

Length: one function per job (thirteen), each a thin layer over its module; splitting them
would scatter the one place where the defaults live.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import frictionrt.rt.common  # noqa: F401  (BLAS, numba's target and cache before any kernel loads)
from frictionrt.results import Result
from frictionrt.rt.common.config import DEFAULT_ESTIMATOR, ESTIMATORS, Config, dumps, estimator_of, load

Cfg = Config | None


def load_config(path: str | Path | None = None, sets: Sequence[str] = ()) -> Config:
    """The configuration: the spec's defaults, the TOML file ``path`` over them, then each
    ``KEY=VALUE`` of ``sets`` (as ``--config`` and ``--set``; e.g. "tracking.K_f=8.2e9",
    "plant.screws.adaptive.F_N=200"). ConfigError names a bad key or value and its allowed range."""
    return load(None if path is None else str(path), list(sets))


def show_config(cfg: Cfg = None) -> str:
    """The resolved configuration as TOML, loadable by ``load_config`` (``frictionrt config --show``)."""
    return dumps(_cfg(cfg))


def _cfg(cfg: Cfg) -> Config:
    return load() if cfg is None else cfg


def nyquist_hz(cfg: Cfg = None) -> float:
    """Half the loop's rate [Hz] (10500 Hz at 21 kHz): excitation frequencies lie in (0, nyquist)."""
    return 0.5 / _cfg(cfg).dt_s


def check_frequency(freq_hz: float, cfg: Cfg = None, what: str = "frequency") -> float:
    """``freq_hz`` if it lies in (0, Nyquist) [Hz], the one range every job measures in (a sine at
    0 Hz has no harmonic to measure; at or above Nyquist it aliases); ValueError otherwise."""
    top = nyquist_hz(cfg)
    if not (math.isfinite(freq_hz) and 0.0 < freq_hz < top):
        raise ValueError(f"{what} {freq_hz:g} Hz: give a frequency in (0, {top:g}) Hz (above 0, below Nyquist)")
    return float(freq_hz)


def modes(cfg: Cfg = None) -> Result:
    """Eigenfrequencies [Hz] of the bare beam and of the assembly (stuck contact, full FE and the
    reduced model), DOF counts and k_T at the adaptive screw (``frictionrt modes``)."""
    from frictionrt.plant.modes import format_summary, modes_summary
    s = modes_summary(_cfg(cfg))
    return Result("modes", s, text=format_summary(s))


def impulse(cfg: Cfg = None, *, fn1_n: float | None = None, error_estimate: bool = False) -> Result:
    """The simulated hammer test at constant F_N1 = ``fn1_n`` [N] (None: the adaptive screw's
    configured preload): accelerance FRF [(m/s^2)/N], natural frequencies [Hz] and damping
    ratios of modes 2-5 (``frictionrt impulse``). ``error_estimate``: also the test on the plant
    with the contact pitch and the elements x2, and ``refined_shift`` {freq_hz, damping_ratio}:
    each figure's estimated shift under refinement (Richardson, order 1;
    rt.experiments.discretisation). ``.plot()``: the FRF (cf. the paper's Fig. 5); ``.frf``: the
    ``plant.impulse.ImpulseResult``."""
    from frictionrt.plant.impulse import impulse_test, plot_frf
    from frictionrt.plant.model import build_plant
    from frictionrt.rt.common.config import adaptive_screw
    cfg = _cfg(cfg)
    screw = adaptive_screw(cfg)
    if screw is None and fn1_n is not None:
        raise ValueError(f"fn1_n {fn1_n:g} N: this structure has no adaptive screw (no plant.screws entry with "
                         "adaptive = true) to set; leave it out")
    fn1 = (0.0 if screw is None else screw.F_N) if fn1_n is None else float(fn1_n)
    t = cfg.tracking
    if screw is not None and not (t.F_min_N <= fn1 <= t.F_max_N):
        raise ValueError(f"F_N1 {fn1:g} N lies outside [F_min, F_max] = [{t.F_min_N:g}, {t.F_max_N:g}] N")
    res = impulse_test(build_plant(cfg), fn1)
    data = res.to_json()
    text = [f"impulse test, {'no adaptive screw' if screw is None else f'F_N1 = {fn1:g} N'}, "
            f"hammer {cfg.impulse.peak_N:g} N / {1e3 * cfg.impulse.duration_s:g} ms"]
    if not error_estimate:
        text.append(f"{'mode':>4} {'f [Hz]':>9} {'zeta [%]':>9}")
        text += [f"{m:>4} {f:>9.2f} {100 * z:>9.3f}" for m, f, z in zip(res.modes, res.freq_hz, res.damping_ratio)]
    else:
        from frictionrt.rt.experiments.discretisation import coarser, refined_shift
        coarse = impulse_test(build_plant(coarser(cfg)), fn1)
        shift = {"freq_hz": [refined_shift(float(a), float(b)) for a, b in zip(res.freq_hz, coarse.freq_hz)],
                 "damping_ratio": [refined_shift(float(a), float(b))
                                   for a, b in zip(res.damping_ratio, coarse.damping_ratio)]}
        data["refined_shift"] = {k: [None if v != v else float(f"{v:.6g}") for v in x] for k, x in shift.items()}
        text += ["discretisation error: estimated shift under refinement (Richardson from the contact pitch and "
                 "elements x2, order 1)", f"{'mode':>4} {'f [Hz]':>9} {'shift [%]':>9} {'zeta [%]':>9} {'shift [%]':>9}"]
        text += [f"{m:>4} {f:>9.2f} {100 * df / f:>+9.2f} {100 * z:>9.3f} {100 * dz / z:>+9.0f}"
                 for m, f, z, df, dz in zip(res.modes, res.freq_hz, res.damping_ratio, shift["freq_hz"],
                                            shift["damping_ratio"])]
    return Result("impulse", data, lambda: plot_frf(res, None, cfg.impulse.f_max_hz), "\n".join(text), frf=res)


def simulate(cfg: Cfg = None, *, freq_hz: float, amp_n: float, law: str | None = None,
             estimator: str = DEFAULT_ESTIMATOR, duration_s: float = 1.0, paced: bool = False,
             seed: int | None = None, out: str | Path | None = None, force: bool = False, rrd: bool = True,
             ring_s: float = 1.0, faults: Sequence[str] = (), controller_of=None, progress: bool = False,
             argv: Sequence[str] | None = None, structure: str | Path | None = None, clusters: int = 0,
             clustering: str = "footprint") -> Result:
    """The closed loop at 21 kHz with a sine force of ``amp_n`` [N] at ``freq_hz`` [Hz] for
    ``duration_s`` [s] (``frictionrt simulate``): ``law`` (None: tracking.law) on ``estimator``.
    With ``out`` ("logs/run" or "logs/run.mcap"), every signal is logged to run.mcap, run.rrd (unless
    ``rrd`` is False) and a Foxglove layout run.foxglove.json while the loop runs, through a ring of
    ``ring_s`` [s]. ``faults``: specs ``"KIND[/SENSOR][=VALUE]@TIME[:DURATION]"`` (docs/reliability.md);
    ``controller_of(loop)``: the loop's controller (a C export's, ``frictionrt.rt.export.sil``; None:
    numba's); ``argv``: the command line the log records (None: this process's); ``seed``: the sensor
    noise's (None: rt.seed); ``structure``: a superelement file (docs/superelement.md) as the plant,
    its interface coarsened to ``clusters`` points if > 0 by ``clustering``, recorded in the log (path, SHA-256). Returns the summary (``.to_dict()``: acc045_amplitude [m/s^2],
    fn1_mean_n [N], actuator_energy_j [J], the estimate's NRMSE, overruns, log paths, ...);
    ``.run``: the ``Run`` with every signal (``.run.signal("F_N1")``); ``.plot()``: the response
    and F_N1 over the last 50 ms."""
    import json

    from tqdm import tqdm

    from frictionrt.rt.experiments.compare import plot
    from frictionrt.rt.log.data_format import run_test_record
    from frictionrt.rt.log.design_record import DESIGN_ATTACHMENT, MEDIA_TYPE, design_arrays, to_npz
    from frictionrt.rt.log.writer import open_run_log, run_metadata
    from frictionrt.rt.loop import build_loop, check_run_input, initial_loop_state, run, summary
    from frictionrt.rt.loop.faults import schedule, to_json
    from frictionrt.rt.loop.keyframe import keyframe_codec
    cfg = _cfg(cfg)
    estimator = estimator_of(estimator)
    check_frequency(freq_hz, cfg, "freq_hz (--freq)")
    if seed is not None and seed < 0:
        raise ValueError(f"seed {seed}: must be a non-negative integer")
    if not ring_s > 0:
        raise ValueError(f"ring {ring_s:g} s: must be > 0 s")
    base = None
    if out is not None:
        base = Path(out)
        if base.suffix in (".mcap", ".rrd"):
            base = base.with_suffix("")
        if not base.parent.exists():
            raise ValueError(f"out {out}: folder {base.parent} does not exist")
        outputs = [base.with_name(base.name + s) for s in (".mcap", ".foxglove.json", *((".rrd",) if rrd else ()))]
        if not force and (taken := [str(p) for p in outputs if p.exists()]):
            raise FileExistsError(f"out {out}: {', '.join(taken)} exist(s); pass force (--force) to replace, "
                                  "or give a new name")
    fault_rows = schedule(list(faults), cfg)
    if not paced and any("cpu_stall" in f for f in faults):
        raise ValueError("--fault cpu_stall: a CPU stall is seen as overruns of the paced loop only; add --paced "
                         "(paced=True)")
    from frictionrt.rt.loop.structure import structure_of
    structure_ = None if structure is None else structure_of(structure, clusters, clustering)
    loop = build_loop(cfg, law, estimator, structure=structure_)
    n = check_run_input(loop, freq_hz, amp_n, duration_s, ring=base is not None)  # out: a ring
    late = [f for f, row in zip(faults, fault_rows) if row[2] >= n]
    if late:
        raise ValueError(f"fault {late[0]!r}: starts after the run's end ({duration_s:g} s); give a TIME below it")
    seed_ = cfg.rt.seed if seed is None else seed
    # the C export before the log is opened: a bad one leaves no files
    controller = None if controller_of is None else controller_of(loop)
    writer = None
    try:
        if base is not None:
            meta = run_metadata(cfg, loop.law, loop.estimator, seed_, freq_hz, amp_n, duration_s, paced, argv=argv)
            meta["faults"] = json.dumps(to_json(fault_rows))
            meta["controller_design"] = design_hash_of(loop, seed_)   # what export-c writes for it
            if structure_ is not None:
                meta["structure"] = structure_.record()
            writer = open_run_log(base, loop.signals, 1.0 / cfg.dt_s, meta, rrd=rrd, ring_s=ring_s,
                                  keyframes=keyframe_codec(loop, initial_loop_state(loop, seed_)))
            writer.mcap.add_metadata("test", run_test_record(loop, freq_hz, amp_n, duration_s))
            writer.mcap.add_attachment(DESIGN_ATTACHMENT, MEDIA_TYPE,
                                       to_npz(design_arrays(loop, initial_loop_state(loop, seed_))))
        with tqdm(total=n, unit="tick", unit_scale=True, disable=not progress, desc=f"simulate {loop.law}") as bar:
            r = run(loop, freq_hz, amp_n, duration_s, paced=paced, seed=seed, progress=bar.update,
                    writer=writer, faults=fault_rows, controller=controller)
    finally:
        if writer is not None:
            writer.finish()  # idempotent: closes the files also if the run never started
    if len(r.log) < 2:
        raise KeyboardInterrupt("interrupted before the loop ran: nothing to summarise")
    s = summary(r)
    s["interrupted"] = r.interrupted or (writer is not None and writer.interrupted)
    if writer is not None:
        s |= {"mcap": writer.paths["mcap"], "rrd": writer.paths["rrd"], "foxglove_layout": writer.paths["foxglove"],
              "dropped_blocks": writer.dropped_blocks, "unwritten_ticks": writer.unwritten_ticks}
    return Result("simulate", s, lambda: plot({loop.law: r}), run=r)


def design_hash_of(loop, seed: int) -> str:
    """The design hash of the controller of a run of ``loop`` (a log stores it as
    "controller_design"; ``export_c`` writes the same into a C export of the design)."""
    from frictionrt.rt.export.record import controller_record, design_hash
    from frictionrt.rt.loop import initial_loop_state
    return design_hash(controller_record(loop, initial_loop_state(loop, seed)))


def compare(cfg: Cfg = None, *, mode: int = 3, amp_n: float = 5.0, duration_s: float = 1.0,
            freq_hz: float | None = None, estimator: str = DEFAULT_ESTIMATOR, controller_of=None,
            progress: bool = False, structure: str | Path | None = None, clusters: int = 0,
            clustering: str = "footprint") -> Result:
    """The three laws (passive, hysteresis-optimal, Lyapunov) at one excitation (``frictionrt
    compare``): ``amp_n`` [N] at ``freq_hz`` [Hz], by default the passive law's peak of bending mode
    ``mode`` (found by a short step-sine), ``duration_s`` [s] each. ``.to_dict()``: {"freq_hz",
    "rows": per law acc045_amplitude [m/s^2], change_pct against passive [%] (negative: lower), fn1_mean_n [N],
    actuator_energy_j [J]}; ``.plot()``: the response and F_N1 over the last 50 ms.
    ``controller_of(loop)``: the controller a law's loop runs (a C export's; None: numba's).
    ``structure``: a superelement file as the plant, coarsened to ``clusters`` points if > 0 by ``clustering`` (its
    ``mode`` counted among the modes the laws act on, rt.experiments.stepsine.structure_mode_bands_hz)."""
    from tqdm import tqdm

    from frictionrt.rt.common.config import LAWS
    from frictionrt.rt.experiments.compare import compare as run_compare
    from frictionrt.rt.experiments.compare import passive_peak_hz, plot, table
    from frictionrt.rt.loop import Designs, build_loop, check_run_input
    cfg = _cfg(cfg)
    estimator = estimator_of(estimator)
    if freq_hz is None and not 1 <= mode <= 9:
        raise ValueError(f"mode {mode}: give a bending mode 1..9")
    if freq_hz is not None:
        check_frequency(freq_hz, cfg, "freq_hz (--freq)")
    if not amp_n > 0:   # the table is relative to the passive response, which 0 N leaves at 0
        raise ValueError(f"amplitude {amp_n:g} N: compare needs a finite force > 0 N, e.g. 5")
    from frictionrt.rt.loop.structure import structure_of
    structure_ = None if structure is None else structure_of(structure, clusters, clustering)
    designs = Designs()   # the plant and force-tracking designs, made once for the three laws
    passive = build_loop(cfg, "passive", estimator, designs=designs, structure=structure_)
    if freq_hz is None:
        check_run_input(passive, 1.0, amp_n, duration_s)  # amplitude and duration before the search
        with tqdm(unit="point", disable=not progress, desc=f"passive peak of mode {mode}") as bar:
            freq_hz = round(passive_peak_hz(passive, mode, amp_n, progress=bar.update, designs=designs), 2)
    n = check_run_input(passive, freq_hz, amp_n, duration_s)
    with tqdm(total=len(LAWS) * n, unit="tick", unit_scale=True, disable=not progress, desc="compare") as bar:
        runs = run_compare(cfg, freq_hz, amp_n, duration_s, estimator, progress=bar.update,
                           controller_of=controller_of, designs=designs, structure=structure_)
    rows = table(runs)
    doc = {"freq_hz": freq_hz, "amp_n": amp_n, "duration_s": duration_s, "estimator": estimator.value, "rows": rows}
    if structure_ is not None:
        import json
        doc["structure"] = json.loads(structure_.record())
    return Result("compare", doc, lambda: plot(runs), runs=runs)


def frf(cfg: Cfg = None, *, laws: Sequence[str], amps_n: Sequence[float], freqs_hz: Sequence[float] | None = None,
        around_modes: Sequence[int] | None = None, points: int = 31, half_width: float = 0.15, down: bool = False,
        sweep_rate_hz_s: float | None = None, tol: float = 0.01, max_time_s: float = 8.0,
        estimator: str = DEFAULT_ESTIMATOR, jobs: int | None = None, dask: str | None = None,
        controller_of=None, progress: bool = False, structure: str | Path | None = None, clusters: int = 0,
        clustering: str = "footprint") -> Result:
    """Amplitude-controlled step-sine FRFs [(m/s^2)/N] (``frictionrt frf``): one sweep per law of
    ``laws`` and force amplitude of ``amps_n`` [N], over ``freqs_hz`` [Hz] or ``points`` frequencies
    over +/- ``half_width`` (relative) around each mode of ``around_modes``, up (or ``down``); a point
    is measured once H has settled to ``tol`` (relative) or after ``max_time_s`` [s]. With
    ``sweep_rate_hz_s`` [Hz/s]: a slow continuous sweep over the range instead. ``.to_dict()``:
    {"dt_s", "config" (TOML), "results": one ``StepSineResult.to_dict()`` per sweep}; ``.results``:
    the ``StepSineResult`` objects; ``.plot()``: |H| and phase. ``structure``: a superelement file as
    the plant, coarsened to ``clusters`` points if > 0 by ``clustering`` (``around_modes`` counted among the modes the
    laws act on, rt.experiments.stepsine.structure_mode_bands_hz; "structure" in ``.to_dict()``)."""
    from frictionrt.rt.experiments.branches import Branch, run_branches
    from frictionrt.rt.experiments.stepsine import Settle, mode_bands_hz, plot_frfs, resonance_grid
    cfg = _cfg(cfg)
    estimator = estimator_of(estimator)
    for a in amps_n:
        if not (math.isfinite(a) and a > 0.0):
            raise ValueError(f"amplitude {a:g} N: an FRF needs a finite force amplitude > 0 N")
    if (freqs_hz is None) == (around_modes is None):
        raise ValueError("give the frequencies (--freqs) or the modes to resolve (--around-modes), one of them")
    from frictionrt.rt.loop import Designs
    from frictionrt.rt.loop.structure import structure_of
    structure_ = None if structure is None else structure_of(structure, clusters, clustering)
    designs = Designs()   # the plant, built once for the bands and the loops
    if sweep_rate_hz_s is not None and not (math.isfinite(sweep_rate_hz_s) and sweep_rate_hz_s > 0.0):
        raise ValueError(f"sweep rate {sweep_rate_hz_s:g} Hz/s: must be a finite rate > 0 (e.g. 0.5; down for a "
                         "down-sweep)")
    if freqs_hz is not None:
        freqs = [check_frequency(float(f), cfg) for f in freqs_hz]
    else:
        if points < 1:
            raise ValueError(f"points {points}: give at least 1 frequency per mode")
        bands = mode_bands_hz(cfg, tuple(int(m) for m in around_modes), designs, structure_)
        freqs = [float(f) for f in resonance_grid([0.5 * sum(bands[m]) for m in bands], half_width, points)]
    freqs = sorted(set(freqs), reverse=down)
    settle = Settle(rel_tol=tol, max_s=max_time_s)
    rate = sweep_rate_hz_s
    try:
        if rate is None:
            settle.check(freqs, cfg.dt_s)
    except ValueError as exc:
        raise ValueError(str(exc).replace("settle.rel_tol", "tol (--tol)").replace("settle.max_s", "max_time_s "
                                                                                   "(--max-time)")) from None
    if rate is not None:
        if len(freqs) < 2:
            raise ValueError("sweep rate: the frequency range is a single frequency; give two or more frequencies")
        freqs = [freqs[0], freqs[-1]]   # the range, in sweep order
        rate = -rate if down else rate
    branches = [Branch(cfg, law, float(a), tuple(freqs), estimator.value, settle, sweep_rate_hz_s=rate,
                       structure=structure_) for law in laws for a in amps_n]
    from frictionrt.rt.experiments.branches import build_loops
    loops = None if structure_ is None else build_loops(branches, designs)
    if controller_of is not None:   # each law with a C export runs it (worker processes load it by path)
        from dataclasses import replace
        loops = build_loops(branches, designs) if loops is None else loops
        branches = [replace(b, controller=controller_of(lp)) for b, lp in zip(branches, loops)]
    results = run_branches(branches, jobs=jobs, dask_address=dask, progress=progress, loops=loops)
    doc = {"dt_s": cfg.dt_s, "config": dumps(cfg), "results": [r.to_dict() for r in results]}
    if structure_ is not None:
        import json
        doc["structure"] = json.loads(structure_.record())
    return Result("frf", doc, lambda: plot_frfs(results), results=results)


def reproduce(cfg: Cfg = None, *, quick: bool = False, estimators: Sequence[str] = ESTIMATORS,
              modes: Sequence[int] | None = None, amps_n: Sequence[float] | None = None,
              out: str | Path | None = None, force: bool = False, jobs: int | None = None, dask: str | None = None,
              progress: bool = False, stage=None, error_estimate: str = "auto") -> Result:
    """The paper's experiments and claims C1..C6 (``frictionrt reproduce``; docs/experiments.md):
    the impulse test, step-sine FRFs of passive, hysteresis-optimal and Lyapunov control around the
    resonances at several force amplitudes (the laws on each of ``estimators``: the paper's observer
    first, on which the claims are decided, the oracle beside it), and the best constant F_N1. The
    full plan: modes 2-5 at 5, 10, 20 N; ``quick``: modes 3, 4 at 5, 20 N on a coarse grid;
    ``modes``/``amps_n``: the plan on those only. With ``out``: fig5.png, fig7.png, fig8.png,
    report.md, report.json written there at once. ``.to_dict()`` is report.json (``claims`` ->
    C1..C6 -> holds, numbers; ``peak_change_db`` -> law -> mode -> amplitude [dB], negative: the
    law's peak is lower; per claim ``margin``, ``refined_shift``, ``verdict``: yes / NO / undecided);
    ``error_estimate``: "auto" (the stored margins of the coarse and refined plants for this
    configuration and plan, else their runs), "run" or "none" (rt.experiments.discretisation);
    ``.plot(law)``: the law against passive ("hysteresis": Fig. 7, "lyapunov": Fig. 8).
    ``stage(text)``: told each stage as it starts."""
    import dataclasses

    from frictionrt.rt.experiments.reproduce import FULL, QUICK, measure
    from frictionrt.rt.experiments.reproduce_report import jsonable, plot_laws, write_outputs
    cfg = _cfg(cfg)
    estimators = tuple(estimator_of(e).value for e in estimators)
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs {jobs}: must be >= 1 (local worker processes)")
    if out is not None and Path(out).exists() and not force:
        raise FileExistsError(f"out {out}: exists; pass force (--force) to replace it as a whole, or give a new folder")
    plan = QUICK if quick else FULL
    if modes is not None:
        plan = dataclasses.replace(plan, modes=tuple(int(m) for m in modes))
    if amps_n is not None:
        plan = dataclasses.replace(plan, amps_n=tuple(float(a) for a in amps_n))
    plan.check(cfg)
    from frictionrt.rt.experiments.discretisation import ErrorEstimate
    try:
        how = ErrorEstimate(error_estimate)
    except ValueError:
        raise ValueError(f"error_estimate {error_estimate!r}: give one of "
                         f"{', '.join(e.value for e in ErrorEstimate)}") from None
    result = measure(cfg, plan, estimators, jobs, dask, progress=progress, stage=stage or (lambda text: None),
                     error_estimate=how)
    if out is not None:
        from frictionrt.rt.common.files import write_folder
        write_folder(out, force, lambda: write_outputs(Path(out), result, cfg.impulse.f_max_hz))
    titles = {"hysteresis": "Hysteresis-optimal vs passive", "lyapunov": "Lyapunov vs passive"}

    def plot(law: str = "hysteresis"):
        if law not in titles:
            raise ValueError(f"law {law!r}: plot one of {', '.join(titles)} against passive")
        return plot_laws(result["frfs_by_estimator"], law, None, titles[law])

    rep = ReproduceResult("reproduce", jsonable(result["report"]), None, raw=result)
    rep.plot = plot
    return rep


class ReproduceResult(Result):
    """``reproduce``'s result: ``plot(law="hysteresis")`` draws one law against passive."""

    def verdicts(self) -> dict[str, dict[str, bool]]:
        """Estimator -> claim -> holds (True / False)."""
        return {e: {c: v["claims"][c]["holds"] for c in v["claims"]} for e, v in self["by_estimator"].items()}


def tune(cfg: Cfg = None, *, law: str, grid: Mapping[str, Sequence[float]] | None = None,
         modes: Sequence[int] = (3, 4), amps_n: Sequence[float] = (5.0,), points: int = 9,
         half_width: float = 0.15, estimator: str = DEFAULT_ESTIMATOR, max_power_w: float | None = None,
         jobs: int | None = None, dask: str | None = None, out: str | Path | None = None, force: bool = False,
         progress: bool = False, structure: str | Path | None = None, clusters: int = 0,
         clustering: str = "footprint"):
    """Grid search of a law's gains (``frictionrt tune``; docs/tuning.md): every combination of
    ``grid`` (configuration key -> values; None: the law's own default grid) is a candidate, scored
    by step-sine sweeps of ``points`` frequencies over +/- ``half_width`` around ``modes`` at each
    force amplitude of ``amps_n`` [N]: ``peak_change_db`` (mean 20 log10(peak_law / peak_passive),
    negative = lower peak) and ``power_w`` (mean actuator power [W]); the best has the lowest peak
    change (within ``max_power_w``). With ``out``: table.csv, table.md, pareto.png, best.toml,
    tune.json. Returns the ``TuneResult`` (``.to_dict()``, ``.rows()``, ``.best_cfg``, ``.plot()``,
    ``.warnings``: the grid's resolution of the passive peak, checked). ``structure``: a superelement
    file as the plant of every sweep, coarsened to ``clusters`` points if > 0 by ``clustering`` (``modes`` counted among
    the modes the laws act on, rt.experiments.stepsine.structure_mode_bands_hz); best.toml names it."""
    from frictionrt.rt.experiments.tune import DEFAULT_GRIDS, TUNED_LAWS, write_outputs
    from frictionrt.rt.experiments.tune import tune as run_tune
    cfg = _cfg(cfg)
    if law not in TUNED_LAWS:
        raise ValueError(f"law {law!r}: tune one of {', '.join(TUNED_LAWS)} (passive has no gains)")
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs {jobs}: must be >= 1")
    if out is not None and Path(out).exists() and not force:
        raise FileExistsError(f"out {out}: exists; pass force (--force) to replace its tune files, or give a new folder")
    g = {k: tuple(float(v) for v in vs) for k, vs in (DEFAULT_GRIDS[law] if grid is None else grid).items()}
    from frictionrt.rt.loop.structure import structure_of
    structure_ = None if structure is None else structure_of(structure, clusters, clustering)
    res = run_tune(cfg, law, g, tuple(int(m) for m in modes), tuple(float(a) for a in amps_n), points=points,
                   half_width_rel=half_width, estimator=estimator_of(estimator).value, max_power_w=max_power_w,
                   jobs=jobs, dask_address=dask, progress=progress, structure=structure_)
    if out is not None:
        write_outputs(res, Path(out))
    return res


def replay(path: str | Path, cfg: Cfg = None, *, c: str | Path | None = None, plant: bool = False,
           paced: bool = False, sets: Sequence[str] = (), cc: str = "cc", c_opt: str = "-O2") -> Result:
    """Replay a log (``frictionrt replay``; docs/loop.md): its sensor stream through the numba
    controller (default), through the C export in folder ``c``, or with ``plant`` its commands
    through the actuator and the plant; compared bit for bit with what the log recorded.
    ``cfg``: the configuration for a log that stores none; ``sets``: overrides on the stored one.
    ``.to_dict()``: bit_exact (None: nothing recorded to compare), max_abs_diff, first_mismatch_tick,
    missing_ticks, the design's source and the set-up's changes since the log (``design``), ..."""
    path = Path(path)
    if c is not None:
        from frictionrt.rt.export.replay_c import replay_c
        res = replay_c(path, Path(c), cc=cc, opt=c_opt, fallback_cfg=cfg, sets=list(sets))[0]
    elif plant:
        from frictionrt.rt.loop.replay_plant import replay_plant
        res = replay_plant(path, fallback_cfg=cfg, sets=list(sets))
    else:
        from frictionrt.rt.loop.replay import replay as run_replay
        res = run_replay(path, paced=paced, fallback_cfg=cfg, sets=list(sets))
    return Result("replay", res)


def export_c(cfg: Cfg = None, *, out: str | Path, law: str | None = None, estimator: str = DEFAULT_ESTIMATOR,
             from_log: str | Path | None = None, sets: Sequence[str] = (), force: bool = False,
             precision: str = "double", structure: str | Path | None = None, clusters: int = 0,
             clustering: str = "footprint") -> Result:
    """The controller as C99 (``frictionrt export-c``; docs/export-c.md): tip integrator, estimator,
    law, supervisor, prefilter and force tracking of ``law`` (None: tracking.law) on ``estimator``,
    designed from ``cfg``, or the design stored in the log ``from_log`` (``sets``: overrides on its
    configuration), written into the folder ``out`` (with ``force`` an existing one is replaced as a
    whole). ``precision`` "double" (bit-exact with the numba controller) or "float32" (the
    single-precision kind, rt/export/float32.py: observer build only, needs a C compiler).
    ``structure``: a superelement file as the plant the controller is designed for (its
    observer's model and the golden vectors' closed loop), coarsened to ``clusters`` points if > 0 by ``clustering``
    (with ``from_log``, the log's own structure is used). ``.to_dict()``: the manifest (law,
    estimator, design_hash, source, ...) and "folder"."""
    from frictionrt.rt.common.files import write_folder
    from frictionrt.rt.export.generate import export_c as write_export
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not force:
        raise FileExistsError(f"out {out}: exists; pass force (--force) to replace it as a whole, or give a new folder")
    if not out.parent.exists():
        raise ValueError(f"out {out}: folder {out.parent} does not exist")
    cfg = _cfg(cfg)
    if from_log is not None and structure is not None:
        raise ValueError("--structure with --from-log: the log names its own structure; drop --structure")
    if from_log is not None:
        from frictionrt.rt.export.replay_c import log_design
        _, _, _, loop, st, report = log_design(Path(from_log), cfg, list(sets))
        source = f"the log {from_log} ({report['why']})"
    else:
        from frictionrt.rt.loop import build_loop, initial_loop_state
        from frictionrt.rt.loop.structure import structure_of
        structure_ = None if structure is None else structure_of(structure, clusters, clustering)
        loop = build_loop(cfg, law, estimator_of(estimator), structure=structure_)
        st = initial_loop_state(loop, cfg.rt.seed)
        source = "the resolved configuration" + ("" if structure_ is None else f" on the structure {structure_.path}")
    if precision == "float32":
        from frictionrt.rt.export.float32 import export_float32 as write_export
    elif precision != "double":
        raise ValueError(f"precision {precision!r}: give double or float32")
    m = write_folder(out, force, lambda: write_export(loop, st, out, source))
    return Result("export-c", m | {"folder": str(out)})


def effects() -> Result:
    """The effects library the rig hides and the diagnosis names (``frictionrt rig --list``):
    per effect its name, parameter, unit, default strength, bounds, implemented, kind (effect or model
    form: the model-form candidates of rt.discrepancy.effects.MODEL_FORMS follow the effects)."""
    from frictionrt.rt.discrepancy.effects import EFFECTS, MODEL_FORMS
    rows = [e.to_json() for e in [*EFFECTS.values(), *MODEL_FORMS.values()]]
    text = "\n".join(f"{r['name']:<20} {r['parameter']} [{r['unit']}] default {r['default_strength']:.4g}, "
                     f"bounds {r['bounds'][0]:.4g}..{r['bounds'][1]:.4g}"
                     f"{'' if r['implemented'] else '  (not implemented yet)'}"
                     f"{'  (model form)' if r['kind'] == 'model form' else ''}" for r in rows)
    return Result("effects", {"effects": rows}, text=text)


def rig(cfg: Cfg = None, *, effect: str, out: str | Path, strength: float | None = None, seed: int = 0,
        record_s: float = 1.0, stepsine: bool = False, frf_files: bool = False, quantity: str = "accelerance",
        force_scale: float | None = None, levels: Sequence[float] | None = None, excitation: str = "stepsine",
        model_form: str | None = None, refine: str | None = None, force: bool = False, progress=None) -> Result:
    """The virtual rig (``frictionrt rig``; docs/discrepancy.md): a campaign of measurements of the
    configured structure with one hidden ``effect`` ("none", or a name of ``effects()``) at
    ``strength`` (None: its default), ``seed`` for the scatter, hammer hits and noise, written into
    the new folder ``out``: impulse records of ``record_s`` [s] and actuator tests (and step-sine
    tests with ``stepsine``) as MCAP logs; or with ``frf_files`` FRF files (CSV/UFF with sidecars)
    of ``quantity`` (accelerance, mobility, receptance), per drive volt with ``force_scale`` [N/V];
    with ``levels`` (force amplitudes [N], or drive voltages [V] with ``force_scale``) stepped-sine
    or random (``excitation``) tests at each level. ``model_form`` ("all" or parts) gives the truth
    another model form, ``refine`` a refinement factor of it. ``.to_dict()``: folder, files."""
    import math

    from frictionrt.rt.common.files import write_folder
    from frictionrt.rt.discrepancy.effects import EFFECTS, get
    from frictionrt.rt.discrepancy.rig import (make_campaign, make_frf_campaign, make_level_campaign,
                                               model_form as truth_form, model_form_parts, model_form_refine)
    cfg = _cfg(cfg)
    out = Path(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not force:
        raise FileExistsError(f"rig -o {out}: exists; pass --force to replace it as a whole, or give a new folder")
    if effect != "none":
        try:
            eff = get(effect)
        except ValueError as exc:
            raise ValueError(f"rig --effect: {exc}") from None
        if not eff.implemented:
            raise ValueError(f"rig --effect {eff.name}: not implemented yet (needs new kernel code); implemented: "
                             + ", ".join(n for n, e in EFFECTS.items() if e.implemented))
        p = eff.parameter
        if strength is not None and not (math.isfinite(strength) and p.lo <= strength <= p.hi):
            raise ValueError(f"rig --strength {strength:g}: {eff.name} takes {p.name} in [{p.lo:g}, {p.hi:g}] {p.unit}")
    elif strength is not None:
        raise ValueError("rig --strength: --effect none takes no strength")
    if not (math.isfinite(record_s) and 0.2 <= record_s <= 10.0):
        raise ValueError(f"rig --record-s {record_s:g}: give 0.2 .. 10 s")
    if frf_files and (stepsine or record_s != 1.0):
        raise ValueError("rig --frf-files: --stepsine and --record-s apply to the time-series campaign only; drop them")
    if not frf_files and (quantity != "accelerance" or force_scale is not None):
        raise ValueError("rig --quantity, --force-scale: they apply to --frf-files only; add it or drop them")
    if force_scale is not None and not (math.isfinite(force_scale) and force_scale > 0):
        raise ValueError(f"rig --force-scale {force_scale:g}: give a force per volt > 0 [N/V]")
    if levels is not None and not frf_files:
        raise ValueError("rig --levels: the level tests are FRF files; add --frf-files")
    if levels is not None and quantity != "accelerance":
        raise ValueError("rig --levels: the level tests are accelerances; --quantity applies to the linear FRF "
                         "files only, drop it")
    if excitation != "stepsine" and levels is None:
        raise ValueError(f"rig --excitation {excitation}: it drives the level tests; add --frf-files --levels A,B,..")
    try:
        form = model_form_parts(model_form)
    except ValueError as exc:
        raise ValueError(f"rig --model-form: {exc}") from None
    if refine is not None and not form:
        raise ValueError(f"rig --refine {refine}: it refines the truth's model form; add --model-form (all or PARTS)")
    try:
        factor = model_form_refine(refine, form)
    except ValueError as exc:
        raise ValueError(f"rig --refine {refine}: {exc}") from None
    if factor is not None:
        try:
            truth_form(cfg, form, factor)
        except ValueError as exc:
            raise ValueError(f"rig --refine {factor}: the refined truth is not a valid configuration ({exc}); "
                             "give a smaller factor") from None

    def write():   # the campaign into the new folder out (moved in once complete; rt.discrepancy.rig.new_folder)
        if levels is not None:
            return make_level_campaign(out, effect, strength, seed=seed, cfg=cfg, force_levels_n=[float(v) for v in levels],
                                       other_form=form, force_scale_N_per_V=force_scale, excitation=excitation,
                                       refine=factor, progress=progress or (lambda msg: None))
        if frf_files:
            return make_frf_campaign(out, effect, strength, seed=seed, cfg=cfg, quantity=quantity,
                                     force_scale_N_per_V=force_scale, other_form=form, refine=factor)
        return make_campaign(out, effect, strength, seed=seed, cfg=cfg, record_s=record_s, stepsine=stepsine,
                             other_form=form, refine=factor)

    try:
        files = write_folder(out, force, write)
    except ValueError as exc:
        raise ValueError(f"rig -o: {exc}") from None
    return Result("rig", {"folder": str(out), "files": [str(f) for f in files]},
                  text=f"{len(files)} files in {out}: " + ", ".join(Path(f).name for f in files))


def diagnose(folder: str | Path, cfg: Cfg = None, *, out: str | Path | None = None, force: bool = False,
             calibrate_on: Sequence[float] | None = None, harmonic_method: str = "df",
             jobs: int | None = None, dask: str | None = None, progress=None, bars: bool = False) -> Result:
    """Find where the model and the measurements disagree and name the missing effect
    (``frictionrt diagnose``; docs/discrepancy.md): calibrate the nominal model ``cfg`` on the
    campaign or FRF-file folder ``folder``, rank the candidate effects by BIC, refit with the named
    one and show the gap shrink. ``calibrate_on`` (drive levels of an FRF folder): calibrate the
    nonlinear model on those levels and predict the others. With ``out``: report.md, report.json,
    the overlay plots, the updated configuration. ``.to_dict()`` is report.json; ``.config``: the
    fitted configuration; ``.plot()``: the measured FRFs against the model before and after, with
    the residual [dB]. ``progress(text)``: told each stage."""
    from frictionrt.rt.common.files import write_folder
    from frictionrt.rt.discrepancy.diagnose import diagnose as run_diagnose
    from frictionrt.rt.discrepancy.diagnose import diagnose_frf, is_frf_folder, public, summary, write_report
    cfg = _cfg(cfg)
    if out is not None and Path(out).exists() and not force:
        raise FileExistsError(f"out {out}: exists; pass force (--force) to replace it as a whole, or give a new folder")
    if jobs is not None and jobs < 1:
        raise ValueError(f"jobs {jobs}: give 1 or more processes")
    if calibrate_on is not None:
        from frictionrt.rt.discrepancy.diagnose.levels import diagnose_levels
        from frictionrt.rt.discrepancy.diagnose.levels_report import summary as levels_summary
        from frictionrt.rt.discrepancy.diagnose.levels_report import write_levels_report
        if not is_frf_folder(folder):
            raise ValueError(f"calibrate_on (--calibrate-on): {folder} is not a folder of FRF files (rig --frf-files "
                             "--levels writes one)")
        res = diagnose_levels(folder, [float(v) for v in calibrate_on], cfg, progress=progress, method=harmonic_method,
                              bars=bars)
        if out is not None:
            write_folder(out, force, lambda: write_levels_report(res, out))
        return Result("diagnose", {k: v for k, v in res.items() if not k.startswith("_")}, text=levels_summary(res),
                      config=res.get("_config"), raw=res)
    if is_frf_folder(folder):
        res = diagnose_frf(folder, cfg, progress=progress, bars=bars)
    else:
        res = run_diagnose(folder, cfg, progress=progress, jobs=jobs, dask_address=dask, bars=bars)
    if out is not None:
        write_folder(out, force, lambda: write_report(res, out))
    return Result("diagnose", public(res), lambda: _diagnose_figure(res), summary(res), config=res.get("_config"),
                  raw=res)


def _diagnose_figure(res: dict):
    """The first test's measured FRF against the model, nominal (before) and diagnosed (after),
    and the model's residual 20 log10(|H_model| / |H_measured|) [dB] below it."""
    import numpy as np
    from matplotlib.figure import Figure

    from frictionrt.rt.discrepancy.diagnose.campaign import frf_overlays
    pl = res["_plots"]
    if "frf_units" in pl:
        name, F_N1, f, H, H0, H1 = pl["frf"][0]
        s = next(iter(H))
        curves, unit = {"measured": H[s], "before": H0[s], "after": H1[s]}, f"{pl['frf_quantity'][name]} |{s}| " \
                                                                             f"[{pl['frf_units'][name]}]"
    else:
        name, F_N1, f, curves = next(iter(frf_overlays(pl)))
        unit = "accelerance |a_frf / F_exc| [(m/s^2)/N]"
    fig = Figure(figsize=(8, 6))
    ax, ar = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 1.3]})
    styles = {"measured": ("k-", "measured"), "before": ("C1--", "nominal model (before)"),
              "after": ("C0-", "diagnosed model (after)")}
    for k, (st, lab) in styles.items():
        ax.loglog(f, np.abs(curves[k]), st, lw=0.8, label=lab)
    for k in ("before", "after"):
        with np.errstate(divide="ignore", invalid="ignore"):
            ar.semilogx(f, 20 * np.log10(np.abs(curves[k]) / np.abs(curves["measured"])), styles[k][0], lw=0.8)
    ar.axhline(0.0, color="k", lw=0.6)
    ax.set_ylabel(unit)
    ar.set_ylabel("model / measured [dB]")
    ar.set_xlabel("frequency [Hz]")
    ax.set_title(f"{name}: F_N1 = {F_N1:.0f} N")
    ax.legend(fontsize=8)
    for a in (ax, ar):
        a.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    return fig


def diagnose_frf_arrays(freq_hz, H: Mapping[str, object], sensors_x_m: Mapping[str, float], cfg: Cfg = None, *,
                        excitation_x_m: float, F_N1_N: float, quantity: str = "accelerance",
                        excitation: str = "force", amplitude_n: float | None = None, out: str | Path | None = None,
                        force: bool = False, progress=None) -> Result:
    """``diagnose`` of FRFs held in numpy arrays: ``freq_hz`` (n,) [Hz], ``H`` sensor name -> complex
    (n,) FRF of ``quantity`` (accelerance [(m/s^2)/N], mobility [(m/s)/N], receptance [m/N]) per unit
    ``excitation`` (force [N] or drive_voltage [V]), the sensors at ``sensors_x_m`` [m] along the
    beam, the excitation at ``excitation_x_m`` [m], the adaptive screw's force ``F_N1_N`` [N] (0: no
    adaptive screw). The arrays are written as an FRF folder (a temporary one; it stays in
    ``out``/data with ``out``) and diagnosed there."""
    import tempfile

    import numpy as np

    from frictionrt.rt.log.frf_files import FORMAT, FRFTest, write_frf_csv
    meta = {"format": FORMAT, "kind": "frf", "excitation_x_m": float(excitation_x_m),
            "sensor_positions_m": {s: float(x) for s, x in sensors_x_m.items()}, "F_N1_N": float(F_N1_N),
            "amplitude_n": amplitude_n, "description": "frictionrt.diagnose_frf_arrays", "quantity": quantity,
            "excitation": excitation}
    test = FRFTest("frf", np.asarray(freq_hz, float), {s: np.asarray(h, complex) for s, h in H.items()}, None, None,
                   meta)
    with tempfile.TemporaryDirectory(prefix="frictionrt-frf-") as tmp:
        write_frf_csv(Path(tmp) / "frf.csv", test)
        return diagnose(tmp, cfg, out=out, force=force, progress=progress)
