"""``frictionrt replay LOG.mcap --c DIR``: the back-to-back test of an exported C controller.

The log's sensor stream goes through the compiled C (``frictionrt.rt.export.cbuild``) as it goes through
the numba controller in ``frictionrt.rt.loop.replay``: the ADC readings a_tip_meas, a_frf_meas, F_strain,
F_cell of each tick (the C integrates a_tip_meas itself), the oracle's u_rel, v_rel of the tick
before (test builds), the overrun flags of a paced run and the fault schedule. Every output,
v_tip_meas and the ``COMMANDED`` signals, is compared with the recorded one bit for bit; the
first differing tick and signal are named.

The export must be of the log's design: the hash of the log's controller record (from the design
the log carries, ``frictionrt.rt.log.design_record.use_logged``) must equal the export's, otherwise the
replay refuses, naming both; it must also equal the hash the log states in its "frictionrt"
record ("controller_design", written by ``simulate --out``), when it states one. Unlike the numba replay, readings that are NaN (logged sensor
dropouts) are fed as they are: the C, like the loop, sanitises them.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from frictionrt.rt.export.cbuild import OUTPUTS, build
from frictionrt.rt.export.generate import check_design, read_manifest
from frictionrt.rt.export.record import TIP_SLOTS, controller_record, design_hash
from frictionrt.rt.log.design_record import use_logged
from frictionrt.rt.loop.build import initial_loop_state
from frictionrt.rt.loop.coverage import coverage
from frictionrt.rt.loop.keyframe import keyframe_parts, load, logged_patterns
from frictionrt.rt.loop.replay import (_overran, compare_bits, controller_restarts, logged_faults, open_controller_log,
                                       oracle_inputs, replay_plan, seed_of)

READINGS = ("a_tip_meas", "a_frf_meas", "F_strain", "F_cell")


def log_design(path: Path, fallback_cfg=None, sets=()):
    """(rec, meta, names, loop, state, design report) of the log at path: the loop rebuilt from
    its stored configuration with the design it carries put in (as ``replay`` does).
    ValueError naming the file for an unsuitable one."""
    rec, cfg, names, loop = open_controller_log(path, fallback_cfg, sets, READINGS)
    meta = rec.metadata
    st = initial_loop_state(loop, seed_of(path, meta, cfg))
    loop, st, report = use_logged(path, loop, st, sets, meta=meta)
    return rec, meta, names, loop, st, report


def ctrl_states(ctrl, loop, st, restart, patterns: bool = True) -> np.ndarray:
    """(restarts, state doubles) ctrl_state images of the key frames in ``restart``
    (``frictionrt.rt.loop.replay.controller_restarts``): each loaded into a copy of the loop state
    ``st``, whose parts then fill ctrl_state's members (``frictionrt.rt.export.sil.STATE_PARTS``: the
    tip integrator's slots of the sensors' state, the estimator's state, RT1, prefilter, PID,
    supervisor). ``patterns``: whether the key frames carry the plant cache's patterns
    (``frictionrt.rt.loop.keyframe.logged_patterns``)."""
    at, kf_f, kf_i = restart[:3]
    slices = ctrl.state_offsets() if len(at) else []
    images = np.zeros((len(at), slices[-1].stop if slices else 1))
    for j in range(len(at)):
        s = st.copy()
        parts = keyframe_parts(s, loop.cfg.rt.keyframe_plant_cache, patterns)
        load(parts, kf_f[j], kf_i[j])
        for sl, x in zip(slices, (s.xs[TIP_SLOTS], s.xe if loop.observes else s.xo, s.xl, s.xq, s.xf,
                                  s.sv)):
            images[j, sl] = x
    return images


def replay_c(path, folder, *, cc=None, opt="-O2", extra=(), fallback_cfg=None, sets=()) -> tuple[dict, np.ndarray]:
    """Replay the log at ``path`` through the C export in ``folder`` (module docstring), built
    with ``cc`` ``opt`` ``extra`` (``frictionrt.rt.export.cbuild.build``). Returns (summary, outputs): the
    JSON summary ``file``, ``export``, ``design_hash``, ``law``, ``estimator``, ``ticks``,
    ``bit_exact``, ``signals_compared``, ``max_abs_diff_by_signal``, ``first_mismatch_tick``,
    ``first_mismatch_signals``, ``build`` (the compile command), ``wall_s``, ``coverage`` (the paths
    the C's outputs took, ``frictionrt.rt.loop.coverage``), ``compared_ranges``, ``missing_ranges``,
    ``not_compared_ranges``, ``restarted_from``, ``restart_note`` (``frictionrt.rt.loop.replay.replay_plan``:
    after a gap the C restarts from the next key frame); outputs (replayed ticks, 13). A float32 export
    (``frictionrt.rt.export.float32``) is compared against its stated bound instead: ``precision``,
    ``equivalence`` (per output max abs and rms of float32 - log), ``within_bound``; ``bit_exact`` None.
    ValueError in one line for a bad log, a folder that is no export, an export of another
    design, a missing compiler or a failed build."""
    path, folder = Path(path), Path(folder)
    manifest = read_manifest(folder)
    rec, meta, names, loop, st, report = log_design(path, fallback_cfg, sets)
    digest = design_hash(controller_record(loop, st))
    check_design(manifest, digest, loop, f"--c {folder}", "the log's",
                 f"; export it with frictionrt export-c --from-log {path}")
    stated = meta.get("controller_design")   # simulate --out stores it (older logs may not)
    if stated is not None and stated != digest and not sets:
        raise ValueError(f"{path}: the log states controller design {stated[:19]}..., its design arrays give "
                         f"{digest[:19]}...: the log was edited or this version reads it otherwise")
    ctrl = build(folder, cc, opt, extra)
    if ctrl.design_hash != digest:
        raise ValueError(f"--c {folder}: its ctrl_config.h names design {ctrl.design_hash[:19]}..., its manifest "
                         f"{digest[:19]}...: the folder was edited; export it again")
    plan = replay_plan(rec)
    uv, overran, restart = controller_restarts(path, rec, plan, loop, st, oracle_inputs(path, rec, names, loop, st),
                                               _overran(rec, names, meta, round(loop.cfg.dt_s * 1e9)))
    ks = rec.k[plan.rows]
    n = len(ks)
    sens = np.ascontiguousarray(rec.log[plan.rows][:, [names.index(c) for c in READINGS]])
    faults = logged_faults(path, meta)
    float32 = manifest.get("precision") == "float32"
    if float32 and len(plan.restart_at):
        raise ValueError(f"--c {folder}: a float32 export replays a log without gaps only (this one restarts at "
                         f"{len(plan.restart_at)} key frames); replay it with a double export")
    states = None if float32 else ctrl_states(ctrl, loop, st, restart, logged_patterns(rec.keyframes))
    t0 = time.perf_counter()
    out = ctrl.run(ks, sens, uv, overran, faults, None if float32 else (plan.restart_at, states))
    wall = time.perf_counter() - t0
    res = {"file": str(path), "export": str(folder), "design_hash": digest, "log_design_hash": stated, "law": loop.law,
           "estimator": loop.estimator, "ticks": n,
           "missing_ticks": sum(b - a + 1 for a, b in plan.report["missing_ranges"]),
           "build": " ".join(ctrl.command), "wall_s": wall, "design": report,
           "coverage": coverage(loop.law, loop.cfg.tracking.F_min_N, loop.cfg.tracking.F_max_N,
                                {c: out[:, j] for j, c in enumerate(OUTPUTS)})}
    owner = {nm: o for nm, _, o in rec.signals}
    cols = [c for c in OUTPUTS if c in owner and f"/{owner[c]}" in rec.topics]
    if len(cols) < len(OUTPUTS):
        res |= {"bit_exact": None, "signals_compared": cols, "max_abs_diff_by_signal": {},
                "first_mismatch_tick": None, "first_mismatch_signals": []}
        return res, out
    res |= plan.report
    ref = rec.log[plan.rows][:, [names.index(c) for c in OUTPUTS]]
    if float32:   # not the double controller's bits: its difference from them against the stated bound
        from frictionrt.rt.export.float32 import differences
        diff = differences(out, ref, n * loop.cfg.dt_s)
        res |= {"precision": "float32", "bit_exact": None, "signals_compared": list(OUTPUTS),
                "equivalence": diff["by_signal"], "within_bound": diff["within_bound"]}
        return res, out
    exact, by_sig, first, at_first = compare_bits(out, ref, OUTPUTS)
    res |= {"bit_exact": exact, "signals_compared": list(OUTPUTS), "max_abs_diff_by_signal": by_sig,
            "first_mismatch_tick": int(ks[first]) if first is not None else None,
            "first_mismatch_signals": at_first}
    return res, out
