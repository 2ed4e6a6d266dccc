"""HIL-style replay of a run log: the recorded sensor stream through the controller stack.

``replay(path)`` reads an MCAP log (``frictionrt.rt.log.mcap_log.read_mcap``), rebuilds the loop from the
configuration TOML, law and estimator in its "frictionrt" metadata record (``build_loop``),
starts every controller state as a run does (``initial_loop_state``) and feeds, tick by tick,
what the controller read at that tick in the loop (``frictionrt.rt.loop.tick._run_ticks``, stage 1 onward):

    sensors     row k of /sensors (a_tip_meas, a_frf_meas, v_tip_meas, F_strain, F_cell): the
                loop logs the readings its sensor stage produced at tick k and the controller
                used at tick k
    oracle      the plant's u_rel, v_rel of row k - 1 of /plant (the plant outputs of the
                previous tick are what the oracle reads at tick k; before the first tick the
                rest state's, zero); only when the estimator was the oracle
    estimator -> law -> supervisor -> prefilter -> force tracking: the loop's own controller
                tick (``frictionrt.rt.loop.tick._controller_tick``, ``_replay_ticks``), with the run's fault
                schedule (metadata "faults": the observer-stage faults act here; the sensor
                faults are in the recorded readings) and its overruns (paced runs: tick_ns +
                late_ns of the tick before)

and compares every commanded signal (the estimator's outputs, F_set, u0, F_set_filtered, V_cmd,
saturated, and the supervisor's fault_code, fault_latched, passive) with the recorded one. For the project's own logs the replay is bit-exact.

A log with gaps (dropped blocks, the lost end of a killed run) is replayed across them
(``replay_plan``): the first run of ticks from the start state, every later one from the first key
frame in it (the loop's state the log carries at fixed tick multiples, ``frictionrt.rt.loop.keyframe``);
the ticks between a gap and that key frame are neither replayed nor compared, and a gap is no
mismatch. A log without key frames (format version 1) is compared up to its first gap.

Non-finite ADC readings (a logged sensor dropout) are fed as they are: the controller saw them,
and its supervisor sanitises them as in the loop. A file with the sensor topic only (a
measurement) and the observer as estimator is replayed without comparison: the controller's outputs are reported (``bit_exact`` None).
"""
from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

import numba
import numpy as np

from frictionrt.observer.step import OBSERVER_OUTPUTS
from frictionrt.rt.common.config import ConfigError, load, loads
from frictionrt.rt.log.design_record import use_logged
from frictionrt.rt.loop import realtime
from frictionrt.rt.loop.faults import from_json
from frictionrt.rt.common.clock import CLK_DEADLINE, CLK_OVERRUNS, CLK_STOP, CLK_TICKS, _now_ns
from frictionrt.rt.loop.coverage import coverage
from frictionrt.rt.loop.build import ALL_ESTIMATORS, build_loop, controller_stages, initial_loop_state
from frictionrt.rt.loop.structure import logged_structure
from frictionrt.rt.loop.driver import watch
from frictionrt.rt.loop.pacing import START_SLACK_NS, _next_deadline, _wait_for_deadline
from frictionrt.rt.loop.tick import _controller_done, _controller_tick
from frictionrt.rt.log.mcap_log import read_mcap, tick_runs
from frictionrt.rt.loop.keyframe import _keyframe_load, keyframe_parts, logged_patterns, views
from frictionrt.rt.loop.keyframe import layout as keyframe_layout
from frictionrt.plant.sensors import SENSOR_OUTPUTS
from frictionrt.rt.loop.supervisor import S_OVERRAN, SUPERVISOR_OUTPUTS
from frictionrt.tracking.force_tracking import FORCE_TRACKING_OUTPUTS
from frictionrt.tracking.laws import LAWS_OUTPUTS
from frictionrt.tracking.prefilter import PREFILTER_OUTPUTS

COMMANDED = tuple(n for n, _ in OBSERVER_OUTPUTS + LAWS_OUTPUTS + PREFILTER_OUTPUTS + FORCE_TRACKING_OUTPUTS
                  + SUPERVISOR_OUTPUTS)
SENSORS = tuple(n for n, _ in SENSOR_OUTPUTS)


@numba.njit(cache=True, nogil=True, _nrt=False)
def _replay_ticks(ks, sens, uv, overran, out, restart, force_col, observe, faults, pace, yc, est, law, sup, trk):
    """The loop's controller tick (``frictionrt.rt.loop.tick._controller_tick``: estimator, law, supervisor,
    force tracking) for the ticks ks: sens[i] the sensor readings (``SENSOR_OUTPUTS`` order),
    uv[i] the plant's (u_rel, v_rel) the oracle reads at tick ks[i], overran[i] whether the
    tick before overran (the supervisor's overrun check); out[i] receives the estimator's, the
    law's, the prefilter's, the force tracking's and the supervisor's outputs (``COMMANDED``
    order). restart = (positions i, float64 and int64 key frames, float64 and int64 parts): before
    tick i = positions[r] the state is set from key frame r (``frictionrt.rt.loop.keyframe._keyframe_load``).
    pace = (paced, period_ns, margin_ns, clk, ts); est, law, sup, trk as ``_controller_tick``
    takes them. Paced: the loop's deadlines (rt/loop/pacing.py)."""
    paced, period_ns, margin_ns, clk, ts = pace
    at, kf_f, kf_i, fv, iv = restart
    sv = sup[0]
    r = 0
    for i in range(ks.shape[0]):
        if clk[CLK_STOP]:
            break
        if r < at.shape[0] and at[r] == i:
            _keyframe_load(kf_f[r], kf_i[r], fv, iv)
            r += 1
        k = ks[i]
        if paced:
            _wait_for_deadline(clk, ts, margin_ns)
        sv[S_OVERRAN] = overran[i]
        _controller_tick(k, sens[i], yc, uv[i, 0], uv[i, 1], force_col, observe, faults, False, ts, est, law, sup, trk)
        _controller_done(out, i, 0, observe, est, law, sup, trk)
        clk[CLK_TICKS] += 1
        if paced:
            _next_deadline(clk, period_ns, _now_ns(ts))


def _config_of(path: Path, meta: dict[str, str], fallback, sets=()):
    """The configuration stored in the log with the ``--set`` overrides ``sets`` applied, or
    ``fallback`` if it stores none."""
    text = meta.get("config")
    if text is None:
        return fallback
    try:
        return loads(text, sets, source="the stored configuration", stored=True)
    except ConfigError as exc:  # names the stored configuration or the --set at fault
        raise ValueError(f"{path}: {exc}") from None


def seed_of(path: Path, meta: dict[str, str], cfg) -> int:
    """The sensor-noise seed stored in the log (``rt.seed`` if none): a non-negative 64-bit
    integer, ValueError naming the file otherwise."""
    text = meta.get("seed")
    if text is None:
        return cfg.rt.seed
    try:
        seed = int(text)
    except ValueError:
        seed = -1
    if not 0 <= seed <= 2**63 - 1:
        raise ValueError(f"{path}: the stored seed {text[:40]!r} is not a non-negative 64-bit integer")
    return seed


def _overran(rec, names: list[str], meta: dict[str, str], period_ns: int) -> np.ndarray:
    """Per replayed tick: 1.0 if the recorded tick before it overran (paced runs: its tick_ns +
    late_ns > period, as the loop decides it), else 0.0; all 0 for offline runs and files without
    the timing signals."""
    out = np.zeros(len(rec.k))
    if meta.get("paced") == "true" and "tick_ns" in names and "late_ns" in names:
        t = rec.log[:, names.index("tick_ns")] + rec.log[:, names.index("late_ns")]
        out[1:] = (t[:-1] > period_ns).astype(float)
    return out


def open_log(path: Path, fallback_cfg=None, sets=()):
    """(``McapLog``, configuration) of the log at path: the stored configuration with the
    ``--set`` overrides ``sets`` applied, or ``fallback_cfg`` (default: the defaults with
    ``sets``) for a file that stores none. ValueError naming the file for a missing or unreadable
    file or a refused configuration."""
    if not path.is_file():
        raise ValueError(f"{path}: {'not a file' if path.exists() else 'no such file'}")
    try:
        rec = read_mcap(path)
    except OSError as exc:
        raise ValueError(f"{path}: cannot read ({exc.strerror or exc})") from None
    return rec, _config_of(path, rec.metadata, fallback_cfg if fallback_cfg is not None else load(None, sets), sets)


def open_controller_log(path: Path, fallback_cfg=None, sets=(), readings=SENSORS):
    """(``McapLog``, configuration, signal names, loop) of the log at path for a replay of its
    controller: ``open_log``, then the loop of the law and estimator it states, built from the
    configuration. ValueError naming the file for one without a /sensors topic holding
    ``readings``, without ticks, with an unknown estimator or a configuration that cannot be built.
    The numba replay and the C's (rt/export/replay_c.py) both open logs here."""
    rec, cfg = open_log(path, fallback_cfg, sets)
    meta = rec.metadata
    names = [n for n, _, _ in rec.signals]
    if "/sensors" not in rec.topics or any(n not in names for n in readings):
        raise ValueError(f"{path}: no /sensors topic with {', '.join(readings)}: nothing to replay")
    if len(rec.k) == 0:
        raise ValueError(f"{path}: the log holds no ticks")
    estimator = meta.get("estimator", "oracle" if "/plant" in rec.topics else "observer")
    if estimator not in ALL_ESTIMATORS:
        raise ValueError(f"{path}: unknown estimator {estimator!r} in the metadata")
    structure = logged_structure(meta, log_path=path)
    try:
        loop = build_loop(cfg, meta.get("law", cfg.tracking.law), estimator, structure=structure)
    except ValueError as exc:
        raise ValueError(f"{path}: the stored configuration cannot be built ({exc})") from None
    return rec, cfg, names, loop


def oracle_inputs(path: Path, rec, names: list[str], loop, st) -> np.ndarray:
    """(ticks, 2): the plant's u_rel, v_rel the oracle reads at each recorded tick (row k - 1 of
    /plant; before the first, the rest state's in ``st``); zeros when the observer is the
    estimator. ValueError naming the file for an oracle log without /plant."""
    uv = np.zeros((len(rec.k), 2))
    if loop.estimator == "oracle":
        if "/plant" not in rec.topics:
            raise ValueError(f"{path}: the oracle estimator reads the plant's u_rel, v_rel, but the file has "
                             "no /plant topic")
        oi = loop.plant.output_index()
        uv[0] = st.yp[[oi["u_rel"], oi["v_rel"]]]
        uv[1:] = rec.log[:-1, [names.index("u_rel"), names.index("v_rel")]]
    return uv


def logged_faults(path: Path, meta: dict[str, str]) -> np.ndarray:
    """The fault schedule the log states (metadata "faults"); ValueError naming the file for an
    unreadable one."""
    try:
        return from_json(json.loads(meta.get("faults", "[]")))
    except ValueError as exc:  # JSONDecodeError included
        raise ValueError(f"{path}: the stored faults are unreadable ({exc})") from None


def compare_bits(out: np.ndarray, ref: np.ndarray, signals) -> tuple[bool, dict[str, float], int | None, list[str]]:
    """Replayed ``out`` against recorded ``ref`` (ticks, len(signals)), bit for bit: (all equal,
    the largest |difference| per signal (inf where one side is NaN), the first row that differs
    (None), the signals that differ there)."""
    same = out.view(np.uint64) == ref.view(np.uint64)
    with np.errstate(invalid="ignore"):
        diff = np.where(same, 0.0, np.abs(out - ref))
    diff = np.where(np.isnan(diff), np.inf, diff)
    by_sig = {c: float(diff[:, j].max(initial=0.0)) for j, c in enumerate(signals)}
    bad = ~same.all(axis=1)
    first = int(np.argmax(bad)) if bad.any() else None
    at_first = [signals[j] for j in np.nonzero(~same[first])[0]] if first is not None else []
    return bool(same.all()), by_sig, first, at_first


def tick_ranges(k: np.ndarray) -> tuple[list[list[int]], list[list[int]]]:
    """(the contiguous runs of logged ticks, the missing ones), each a list of [first, last]
    tick ranges (inclusive), of the increasing ticks k (a log with dropped blocks has gaps)."""
    k = np.asarray(k)
    if len(k) == 0:
        return [], []
    ends = np.nonzero(np.diff(k) != 1)[0]
    starts = np.r_[0, ends + 1]
    ends = np.r_[ends, len(k) - 1]
    present = [[int(k[a]), int(k[b])] for a, b in zip(starts, ends)]
    missing = [[int(k[b]) + 1, int(k[a]) - 1] for b, a in zip(ends[:-1], starts[1:])]
    return present, missing


@dataclass
class ReplayPlan:
    """Which rows of a log a replay runs and where it restarts (``replay_plan``)."""
    rows: np.ndarray        # int64 rows of the log to replay, in order
    restart_at: np.ndarray  # int64 positions in rows where the state is set from a key frame
    keyframe: np.ndarray    # int64 the key frame (row of ``McapLog.keyframes``) of each restart
    report: dict            # compared_ranges, missing_ranges, not_compared_ranges, restarted_from, restart_note


def replay_plan(rec) -> ReplayPlan:
    """The replay of the log ``rec`` (``McapLog``) across its gaps: the first run of contiguous
    ticks from the start state (if it begins at the run's first tick: metadata start_tick; a file
    without it, at its first tick), every later run (and a first one that begins later) from the
    first key frame within it (``frictionrt.rt.log.keyframes``); the ticks between a gap and that key frame
    (all of a run without one) are not replayed. Report: ``compared_ranges``, ``missing_ranges``,
    ``not_compared_ranges`` ([first, last] ticks), ``restarted_from`` (the key frames' ticks) and
    ``restart_note`` (why the replay could not restart after a gap, or None)."""
    k = np.asarray(rec.k)
    kf = rec.keyframes
    start = int(rec.metadata.get("start_tick", k[0] if len(k) else 0))
    _, missing = tick_ranges(k)
    if len(k) and k[0] > start:
        missing.insert(0, [start, int(k[0]) - 1])
    rows, restart_at, kf_rows, compared, not_compared, restarted = [], [], [], [], [], []
    n_rows = 0
    for j, (a, b) in enumerate(tick_runs(k)):
        r0 = None
        if j == 0 and k[a] == start:
            r0 = a
        elif kf is not None:
            i = int(np.searchsorted(kf.k, k[a]))
            if i < len(kf.k) and kf.k[i] <= k[b - 1]:
                r0 = a + int(kf.k[i] - k[a])
                restart_at.append(n_rows)
                kf_rows.append(i)
                restarted.append(int(kf.k[i]))
        if r0 is None:
            not_compared.append([int(k[a]), int(k[b - 1])])
            continue
        if r0 > a:
            not_compared.append([int(k[a]), int(k[r0 - 1])])
        compared.append([int(k[r0]), int(k[b - 1])])
        rows.append(np.arange(r0, b))
        n_rows += b - r0
    note = None
    if not_compared and kf is None:
        note = (f"the log is format version {rec.version}, written before key frames (version 2)" if rec.version < 2
                else "the log carries no key frames (written with rt.keyframe_ticks = 0)") + \
            ": the controller's state after a gap is unknown, so the ticks after the first gap are not compared"
    elif not_compared:
        note = "the ticks between a gap and the next key frame are not compared (their start state is unknown)"
    i64 = np.int64
    return ReplayPlan(np.concatenate(rows).astype(i64) if rows else np.zeros(0, i64), np.array(restart_at, i64),
                      np.array(kf_rows, i64),
                      {"compared_ranges": compared, "missing_ranges": missing, "not_compared_ranges": not_compared,
                       "restarted_from": restarted, "restart_note": note})


def restart_states(path: Path, rec, plan: ReplayPlan, parts) -> tuple[np.ndarray, np.ndarray]:
    """(float64, int64) key-frame rows of the plan's restarts, for the loop state ``parts``
    (``frictionrt.rt.loop.keyframe.keyframe_parts``); ValueError naming the file if the log's key frames
    are not of that layout (a --set that changes a state's size)."""
    if len(plan.restart_at) == 0:
        return np.zeros((0, 1)), np.zeros((0, 1), np.int64)
    codec = rec.keyframes.codec
    if [tuple(p.values()) for p in keyframe_layout(parts)] != list(codec.parts):
        raise ValueError(f"{path}: the log's key frames do not hold this loop's state (another size of a part: "
                         "a --set that changes the model?); replay without restarts is not possible")
    return (np.ascontiguousarray(rec.keyframes.f[plan.keyframe]),
            np.ascontiguousarray(rec.keyframes.i[plan.keyframe]))


def replay(path, *, paced: bool = False, fallback_cfg=None, sets=()) -> dict:
    """Replay the log at ``path`` (module docstring); the summary of ``replay_outputs``."""
    return replay_outputs(path, paced=paced, fallback_cfg=fallback_cfg, sets=sets)[0]


def replay_outputs(path, *, paced: bool = False, fallback_cfg=None, sets=()) -> tuple[dict, np.ndarray, np.ndarray]:
    """Replay the log at ``path`` (module docstring) with its stored configuration and the
    ``--set`` overrides ``sets`` (a changed controller parameter then shows as a mismatch).
    Returns (summary, k, outputs): the ticks
    replayed and the replayed signals (ticks, ``COMMANDED``), and the JSON summary: ``ticks``,
    ``bit_exact`` (None without recorded controller outputs), ``max_abs_diff``,
    ``signals_compared``, and ``file``, ``law``, ``estimator``, ``paced``, ``missing_ticks``
    (gaps in the recorded ticks, e.g. dropped blocks), ``max_abs_diff_by_signal``,
    ``first_mismatch_tick``, ``wall_s``, ``realtime_factor`` (simulated / wall time),
    ``overruns`` (paced), ``interrupted``, ``outputs`` (min, mean, max of each replayed signal),
    ``coverage`` (the paths the replayed outputs took, ``frictionrt.rt.loop.coverage``), and
    ``compared_ranges``, ``missing_ranges``, ``not_compared_ranges``, ``restarted_from``,
    ``restart_note`` (``replay_plan``: after a gap the replay restarts from the next key frame;
    only the replayed ticks are compared and returned).

    ValueError naming the file for a missing, unreadable or unsuitable file.
    """
    path = Path(path)
    rec, cfg, names, loop = open_controller_log(path, fallback_cfg, sets)
    meta = rec.metadata
    law, estimator = loop.law, loop.estimator
    sens = np.ascontiguousarray(rec.log[:, [names.index(n) for n in SENSORS]])
    v_tip = sens[:, SENSORS.index("v_tip_meas")]   # the integrator's output: finite in every run, NaN = no sample
    if not np.all(np.isfinite(v_tip)):
        bad = int(rec.k[~np.isfinite(v_tip)][0])
        raise ValueError(f"{path}: /sensors has missing v_tip_meas samples (first at tick {bad})")
    st = initial_loop_state(loop, seed_of(path, meta, cfg))
    loop, st, design = use_logged(path, loop, st, sets, meta=meta)
    plan = replay_plan(rec)
    period_ns = round(cfg.dt_s * 1e9)
    uv, overran, restart = controller_restarts(path, rec, plan, loop, st, oracle_inputs(path, rec, names, loop, st),
                                               _overran(rec, names, meta, period_ns))
    ks, sens = rec.k[plan.rows], sens[plan.rows]
    n = len(ks)
    si = {nm: i for i, nm in enumerate(SENSORS)}
    force_col = si["F_strain" if loop.force_sensor == "strain" else "F_cell"]
    out = np.full((n, len(COMMANDED)), np.nan)
    clk = np.zeros(4, dtype=np.int64)
    faults = logged_faults(path, meta)
    errors: list[BaseException] = []

    est, law_, sup, trk = controller_stages(loop, st)
    with realtime.session(cfg.rt, paced) as rts:
        fixed = (force_col, loop.observes, faults, (paced, period_ns, rts.margin_ns, clk, np.zeros(2, np.int64)),
                 np.empty(len(SENSORS)), est, law_, sup, trk)
        none = (restart[0][:0], *restart[1:])
        _replay_ticks(ks[:0], sens[:0], uv[:0], overran[:0], out[:0], none, *fixed)  # compile or load: not timed

        def worker():
            try:
                if paced:
                    rts.enter_loop_thread()
                    clk[CLK_DEADLINE] = _now_ns(np.zeros(2, np.int64)) + START_SLACK_NS
                _replay_ticks(ks, sens, uv, overran, out, restart, *fixed)
            except BaseException as exc:
                errors.append(exc)

        # as rt.loop.driver.run: the compiled replay in its own thread, Ctrl-C becomes a stop request
        t0 = time.perf_counter()
        interrupted = watch(worker, "frictionrt-replay", clk)
    wall = time.perf_counter() - t0
    if errors:
        raise errors[0]
    m = int(clk[CLK_TICKS])
    out = out[:m]
    res = {"file": str(path), "law": law, "estimator": estimator, "paced": paced, "ticks": m,
           "missing_ticks": sum(b - a + 1 for a, b in plan.report["missing_ranges"]), "interrupted": interrupted,
           "wall_s": wall, "realtime_factor": (m / rec.rate_hz) / wall if wall > 0 else float("inf"),
           "overruns": int(clk[CLK_OVERRUNS]) if paced else 0, "design": design}
    if paced:
        res["realtime"] = rts.describe()
    owner = {nm: o for nm, _, o in rec.signals}
    recorded = all(c in owner and f"/{owner[c]}" in rec.topics for c in COMMANDED)  # an absent topic reads NaN
    res |= plan.report
    if recorded:
        ref = rec.log[plan.rows[:m]][:, [names.index(c) for c in COMMANDED]]
        exact, by_sig, first, _ = compare_bits(out, ref, COMMANDED)
        res |= {"bit_exact": exact, "max_abs_diff": max(by_sig.values(), default=0.0),
                "signals_compared": list(COMMANDED), "max_abs_diff_by_signal": by_sig,
                "first_mismatch_tick": int(ks[first]) if first is not None else None}
    else:
        res |= {"bit_exact": None, "max_abs_diff": None, "signals_compared": [], "max_abs_diff_by_signal": {},
                "first_mismatch_tick": None}
    res["outputs"] = {c: {"min": float(out[:, j].min(initial=np.inf)), "mean": float(out[:, j].mean()) if m else None,
                          "max": float(out[:, j].max(initial=-np.inf))} for j, c in enumerate(COMMANDED)}
    res["coverage"] = coverage(law, loop.cfg.tracking.F_min_N, loop.cfg.tracking.F_max_N,
                               {c: out[:, j] for j, c in enumerate(COMMANDED)})
    return res, ks[:m], out


def controller_restarts(path: Path, rec, plan: ReplayPlan, loop, st, uv: np.ndarray, overran: np.ndarray):
    """(uv, overran, restart) of the plan's rows: the oracle's inputs and the overrun flags of the
    replayed rows, at a restart those the key frame holds (the plant's u_rel, v_rel at t_k; the
    supervisor's flag of tick k - 1: the rows before are not in the log), and ``_replay_ticks``'
    restart tuple for the state ``st``. The numba and the C replay both take them here."""
    parts = keyframe_parts(st, loop.cfg.rt.keyframe_plant_cache, logged_patterns(rec.keyframes))
    kf_f, kf_i = restart_states(path, rec, plan, parts)
    uv, overran = uv[plan.rows], overran[plan.rows]
    if len(plan.restart_at):
        oi = loop.plant.output_index()
        yp = rec.keyframes.part("plant_y")[plan.keyframe]
        if loop.estimator == "oracle":
            uv[plan.restart_at] = yp[:, [oi["u_rel"], oi["v_rel"]]]
        overran[plan.restart_at] = rec.keyframes.part("supervisor_x")[plan.keyframe, S_OVERRAN]
    return np.ascontiguousarray(uv), np.ascontiguousarray(overran), (plan.restart_at, kf_f, kf_i, *views(parts))
