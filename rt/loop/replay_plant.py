"""Open-loop replay of a log into the plant: recorded commands and excitation in, plant out.

``replay_plant(path)`` reads an MCAP log (``frictionrt.rt.log.mcap_log.read_mcap``), rebuilds actuator and
plant from the configuration stored in its "frictionrt" record (with ``--set`` overrides), starts
them at rest as a run does (``frictionrt.rt.loop.build.initial_loop_state``) and drives them, tick by tick, with

    V_cmd    row k of /tracking: the controller's command at tick k (the DAC input)
    F_exc    row k of /rt: the excitation force held over [t_k, t_k+1)

through the loop's own stages 5 and 6 (``frictionrt.rt.loop.tick._actuate``: actuator over the tick, then the
plant with the mean of F_N1 at t_k and t_k+1), then compares every /actuator and /plant signal
the file holds with the replayed one (row k: values at t_k+1, docs/data-format.md).

Where the cut is. V_cmd is the last signal the controller produces and the first one a real rig
knows exactly (the DAC input; V_a and the bolt force are measured through an amplifier and
sensors). Nothing downstream of it feeds back into the replayed part: the actuator is driven
one-way (the structure does not act back on the stack, plant.actuator) and the sensors,
estimator, law and tracking only read the plant. So the replay is open-loop, and for the
project's own logs bit-exact: the same kernels see the same inputs in the same order from the
same initial state (the contact solver's cache included). After a gap the replay restarts from
the next key frame, which carries the cache's patterns (``frictionrt.rt.loop.keyframe.PATTERNS``):
the factors are refactorised from them (``frictionrt.plant.newmark.refactor_kept``), bit for bit, or
taken whole from a log written with rt.keyframe_plant_cache. Cutting at the actuator's output
(F_N1) would leave the actuator model unchecked, and F_N1 is not measurable on a rig.

Any changed parameter (``--set plant.interface.mu=0.3``) shows as a mismatch. A file without
/actuator and /plant (a measurement) is replayed without comparison (``bit_exact`` None).
"""
from __future__ import annotations

import time
from pathlib import Path

import numba
import numpy as np

from frictionrt.plant.actuator import ACTUATOR_OUTPUTS
from frictionrt.plant.newmark import refactor_kept
from frictionrt.rt.loop.tick import _actuate, _copy, _put
from frictionrt.rt.loop.build import build_loop, initial_loop_state
from frictionrt.rt.loop.structure import logged_structure
from frictionrt.rt.log.design_record import use_logged
from frictionrt.rt.loop.keyframe import CACHE, PATTERNS, keyframe_parts, load, logged_patterns
from frictionrt.rt.loop.replay import compare_bits, open_log, replay_plan, restart_states, seed_of

INPUTS = ("F_exc", "V_cmd")
SUMMARY_SIGNALS = ("F_N1", "V_a", "i", "abar_tip", "abar_frf", "u_rel", "v_rel")  # "outputs" in the JSON


@numba.njit(cache=True, nogil=True, _nrt=False)
def _replay_plant_ticks(ks, F_exc, V_cmd, out, xa, xa_n, ya, ua, act_p, xp, xp_n, yp, up, plant_p, plant_wk, ts):
    """Stages 5 and 6 of ``frictionrt.rt.loop.tick._run_ticks`` (``_actuate``) for the ticks ks with the
    recorded F_exc[i] [N] and V_cmd[i] [V]; out[i] receives the actuator's and then the plant's
    outputs at t_k+1. Returns the number of failed plant solves. RT-safe."""
    failed = 0
    for i in range(ks.shape[0]):
        iters, _ = _actuate(ks[i], F_exc[i], V_cmd[i], xa, xa_n, ya, ua, act_p, xp, xp_n, yp, up, plant_p,
                            plant_wk, False, ts)
        if iters < 0:
            failed += 1
        c = _put(out, i, 0, ya)
        _put(out, i, c, yp)
        _copy(xa_n, xa)
        _copy(xp_n, xp)
    return failed


def replay_plant(path, *, fallback_cfg=None, sets=()) -> dict:
    """Replay the log at ``path`` into actuator and plant (module docstring); the summary of
    ``replay_plant_outputs``."""
    return replay_plant_outputs(path, fallback_cfg=fallback_cfg, sets=sets)[0]


def replay_plant_outputs(path, *, fallback_cfg=None, sets=()) -> tuple[dict, np.ndarray, np.ndarray, list[str]]:
    """Replay the log at ``path`` into actuator and plant (module docstring).

    Returns (summary, k, outputs, names): the ticks replayed, the replayed signals (ticks,
    len(names)) with names the actuator's then the plant's outputs, and the JSON summary:
    ``ticks``, ``bit_exact`` (None when the file holds no /actuator or /plant signal),
    ``max_abs_diff``, ``signals_compared``, and ``file``, ``law``, ``estimator``, ``sets``,
    ``inputs``, ``missing_ticks`` (ticks after the first gap are not replayed: the inputs of the
    gap are unknown), ``max_abs_diff_by_signal``, ``first_mismatch_tick``, ``failed_solves``,
    ``wall_s``, ``outputs`` (min, mean, max of ``SUMMARY_SIGNALS``).

    The configuration is the one stored in the file with ``sets`` applied, or ``fallback_cfg``
    (default: the defaults with ``sets``) for a file that stores none. ValueError naming the
    file for a missing, unreadable or unsuitable file.
    """
    path = Path(path)
    rec, cfg = open_log(path, fallback_cfg, sets)
    meta = rec.metadata
    names = [n for n, _, _ in rec.signals]
    for name, topic in zip(INPUTS, ("/rt", "/tracking")):
        if name not in names or topic not in rec.topics:
            raise ValueError(f"{path}: no {name} in {topic}: the plant replay is driven by F_exc (/rt) and "
                             "V_cmd (/tracking)")
    if len(rec.k) == 0:
        raise ValueError(f"{path}: the log holds no ticks")
    plan = replay_plan(rec)
    if rec.k[0] != 0 and not len(plan.restart_at):
        raise ValueError(f"{path}: the log starts at tick {int(rec.k[0])} and holds no key frame; the plant replay "
                         "starts from rest at tick 0")
    n = len(plan.rows)
    ks = rec.k[plan.rows]
    u = rec.log[plan.rows][:, [names.index(c) for c in INPUTS]]
    if not np.all(np.isfinite(u)):
        bad = int(ks[~np.all(np.isfinite(u), axis=1)][0])
        raise ValueError(f"{path}: F_exc or V_cmd is missing or not finite (first at tick {bad})")
    law = meta.get("law", cfg.tracking.law)
    estimator = meta.get("estimator", "oracle")
    try:
        loop = build_loop(cfg, law, "oracle",  # the estimator plays no part here: no observer design
                          structure=logged_structure(meta, log_path=path))
    except ValueError as exc:
        raise ValueError(f"{path}: the configuration cannot be built ({exc})") from None
    st = initial_loop_state(loop, seed_of(path, meta, cfg))
    loop, st, design = use_logged(path, loop, st, sets, meta=meta, parts=("plant", "actuator"))
    out_names = [nm for nm, _ in ACTUATOR_OUTPUTS] + [nm for nm, _ in loop.plant.output_labels()]
    out = np.empty((n, len(out_names)))
    F_exc = np.ascontiguousarray(u[:, 0])
    V_cmd = np.ascontiguousarray(u[:, 1])
    args = (out, st.xa, np.empty_like(st.xa), st.ya, np.zeros(1), loop.actuator, st.xp, np.empty_like(st.xp), st.yp,
            np.zeros(2), loop.plant.params, st.plant_work, np.zeros(2, np.int64))
    _replay_plant_ticks(ks[:0], F_exc[:0], V_cmd[:0], *args)  # compile or load: not timed
    cache = loop.cfg.rt.keyframe_plant_cache
    if rec.keyframes is not None:   # the observer's state is not replayed here: its size as the log's
        st.xe = np.zeros(rec.keyframes.part("observer_x").shape[1])
    patterns = logged_patterns(rec.keyframes)
    parts = keyframe_parts(st, cache, patterns)
    kf_f, kf_i = restart_states(path, rec, plan, parts)
    cold = loop.plant.new_work()
    bounds = [0, *plan.restart_at.tolist(), n]
    t0 = time.perf_counter()
    failed = 0
    for j, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        if j > 0:   # a restart: the state from the key frame; the factor cache from it, refactorised or cold
            load(parts, kf_f[j - 1], kf_i[j - 1])
            if not cache:
                wk = st.plant_work
                for name in CACHE:
                    if not (patterns and name in PATTERNS):
                        getattr(wk, name)[...] = getattr(cold, name)
                if patterns:   # the factors from the kept patterns, bit for bit (wk.act is scratch there)
                    act = wk.act.copy()
                    refactor_kept(loop.plant.params.W, wk)
                    wk.act[...] = act
        failed += _replay_plant_ticks(ks[a:b], F_exc[a:b], V_cmd[a:b], out[a:b], *args[1:])
    wall = time.perf_counter() - t0
    owner = {nm: o for nm, _, o in rec.signals}
    compared = [c for c in out_names
                if c in owner and owner[c] in ("actuator", "plant") and "/" + owner[c] in rec.topics]
    res = {"file": str(path), "law": law, "estimator": estimator, "sets": list(sets), "inputs": list(INPUTS),
           "ticks": n, "missing_ticks": sum(b - a + 1 for a, b in plan.report["missing_ranges"]),
           "failed_solves": int(failed), "wall_s": wall, "design": design} | plan.report
    res["plant_cache"] = ("in the key frames" if cache else "refactorised from the key frames' patterns" if patterns
                          else "cold after a restart (a log without the cache's patterns in its key frames)")
    exact_all = cache or patterns
    if compared:
        j_out = [out_names.index(c) for c in compared]
        ref = np.ascontiguousarray(rec.log[plan.rows][:, [names.index(c) for c in compared]])
        got = np.ascontiguousarray(out[:, j_out])
        exact_rows = bounds[1] if len(plan.restart_at) and not exact_all else n   # bit for bit: up to a cold restart
        exact, by_sig, first, _ = compare_bits(got[:exact_rows], ref[:exact_rows], compared)
        res |= {"bit_exact": exact, "max_abs_diff": max(by_sig.values(), default=0.0),
                "signals_compared": compared, "max_abs_diff_by_signal": by_sig,
                "first_mismatch_tick": int(ks[first]) if first is not None else None}
        if exact_rows < n:   # after a restart with a cold cache: agreement to round-off, measured
            _, cold_by_sig, cold_first, _ = compare_bits(got[exact_rows:], ref[exact_rows:], compared)
            res["after_cold_restart"] = {
                "signals_differing": sum(1 for v in cold_by_sig.values() if v),
                "max_abs_diff_by_signal": {c: v for c, v in cold_by_sig.items() if c in SUMMARY_SIGNALS + ("F_N1",)},
                "first_differing_tick": int(ks[exact_rows + cold_first]) if cold_first is not None else None}
    else:
        res |= {"bit_exact": None, "max_abs_diff": None, "signals_compared": [], "max_abs_diff_by_signal": {},
                "first_mismatch_tick": None}
    res["outputs"] = {c: {"min": float(out[:, j].min()), "mean": float(out[:, j].mean()),
                          "max": float(out[:, j].max())}
                      for j, c in enumerate(out_names) if c in SUMMARY_SIGNALS}
    return res, ks, out, out_names
