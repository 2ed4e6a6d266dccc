"""``frictionrt replay LOG.mcap --c DIR``: the back-to-back test of an exported C controller.

The log's sensor stream goes through the compiled C (``rt.export.cbuild``) as it goes through
the numba controller in ``rt.loop.replay``: the ADC readings a_tip_meas, a_frf_meas, F_strain,
F_cell of each tick (the C integrates a_tip_meas itself), the oracle's u_rel, v_rel of the tick
before (test builds), the overrun flags of a paced run and the fault schedule. Every output,
v_tip_meas and the ``COMMANDED`` signals, is compared with the recorded one bit for bit; the
first differing tick and signal are named.

The export must be of the log's design: the hash of the log's controller record (from the design
the log carries, ``rt.log.design_record.use_logged``) must equal the export's, otherwise the
replay refuses, naming both; it must also equal the hash the log states in its "frictionrt"
record ("controller_design", written by ``simulate --out``), when it states one. Unlike the numba replay, readings that are NaN (logged sensor
dropouts) are fed as they are: the C, like the loop, sanitises them.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from rt.export.cbuild import OUTPUTS, build
from rt.export.generate import read_manifest
from rt.export.record import controller_record, design_hash
from rt.log.design_record import use_logged
from rt.loop.build import ESTIMATORS, build_loop, initial_loop_state
from rt.loop.faults import from_json
from rt.loop.replay import _overran, open_log, seed_of

READINGS = ("a_tip_meas", "a_frf_meas", "F_strain", "F_cell")


def log_design(path: Path, fallback_cfg=None, sets=()):
    """(rec, meta, names, loop, state, design report) of the log at path: the loop rebuilt from
    its stored configuration with the design it carries put in (as ``replay`` does).
    ValueError naming the file for an unsuitable one."""
    rec, cfg = open_log(path, fallback_cfg, sets)
    meta = rec.metadata
    names = [n for n, _, _ in rec.signals]
    if "/sensors" not in rec.topics or any(n not in names for n in READINGS):
        raise ValueError(f"{path}: no /sensors topic with {', '.join(READINGS)}: nothing to replay")
    if len(rec.k) == 0:
        raise ValueError(f"{path}: the log holds no ticks")
    estimator = meta.get("estimator", "oracle" if "/plant" in rec.topics else "observer")
    if estimator not in ESTIMATORS:
        raise ValueError(f"{path}: unknown estimator {estimator!r} in the metadata")
    try:
        loop = build_loop(cfg, meta.get("law", cfg.tracking.law), estimator)
    except ValueError as exc:
        raise ValueError(f"{path}: the stored configuration cannot be built ({exc})") from None
    st = initial_loop_state(loop, seed_of(path, meta, cfg))
    loop, st, report = use_logged(path, loop, st, sets, meta=meta)
    return rec, meta, names, loop, st, report


def replay_c(path, folder, *, cc=None, opt="-O2", extra=(), fallback_cfg=None, sets=()) -> tuple[dict, np.ndarray]:
    """Replay the log at ``path`` through the C export in ``folder`` (module docstring), built
    with ``cc`` ``opt`` ``extra`` (``rt.export.cbuild.build``). Returns (summary, outputs): the
    JSON summary ``file``, ``export``, ``design_hash``, ``law``, ``estimator``, ``ticks``,
    ``bit_exact``, ``signals_compared``, ``max_abs_diff_by_signal``, ``first_mismatch_tick``,
    ``first_mismatch_signals``, ``build`` (the compile command), ``wall_s``; outputs (ticks, 13).
    ValueError in one line for a bad log, a folder that is no export, an export of another
    design, a missing compiler or a failed build."""
    path, folder = Path(path), Path(folder)
    manifest = read_manifest(folder)
    rec, meta, names, loop, st, report = log_design(path, fallback_cfg, sets)
    digest = design_hash(controller_record(loop, st))
    if digest != manifest["design_hash"]:
        raise ValueError(f"--c {folder}: an export of another design ({manifest['design_hash'][:19]}..., "
                         f"{manifest['law']}/{manifest['estimator']}) than the log's ({digest[:19]}..., "
                         f"{loop.law}/{loop.estimator}); export it with frictionrt export-c --from-log {path}")
    stated = meta.get("controller_design")   # simulate --out stores it (logs before issue 33 do not)
    if stated is not None and stated != digest and not sets:
        raise ValueError(f"{path}: the log states controller design {stated[:19]}..., its design arrays give "
                         f"{digest[:19]}...: the log was edited or this version reads it otherwise")
    ctrl = build(folder, cc, opt, extra)
    if ctrl.design_hash != digest:
        raise ValueError(f"--c {folder}: its ctrl_config.h names design {ctrl.design_hash[:19]}..., its manifest "
                         f"{digest[:19]}...: the folder was edited; export it again")
    n = len(rec.k)
    sens = np.ascontiguousarray(rec.log[:, [names.index(c) for c in READINGS]])
    uv = np.zeros((n, 2))
    if loop.estimator == "oracle":
        if "/plant" not in rec.topics:
            raise ValueError(f"{path}: the oracle estimator reads the plant's u_rel, v_rel, but the file has "
                             "no /plant topic")
        oi = loop.plant.output_index()
        uv[0] = st.yp[[oi["u_rel"], oi["v_rel"]]]
        uv[1:] = rec.log[:-1, [names.index("u_rel"), names.index("v_rel")]]
    try:
        faults = from_json(json.loads(meta.get("faults", "[]")))
    except ValueError as exc:
        raise ValueError(f"{path}: the stored faults are unreadable ({exc})") from None
    overran = _overran(rec, names, meta, round(loop.cfg.dt_s * 1e9))
    t0 = time.perf_counter()
    out = ctrl.run(rec.k, sens, uv, overran, faults)
    wall = time.perf_counter() - t0
    res = {"file": str(path), "export": str(folder), "design_hash": digest, "log_design_hash": stated, "law": loop.law,
           "estimator": loop.estimator, "ticks": n, "missing_ticks": int(rec.k[-1] - rec.k[0] + 1 - n),
           "build": " ".join(ctrl.command), "wall_s": wall, "design": report}
    owner = {nm: o for nm, _, o in rec.signals}
    cols = [c for c in OUTPUTS if c in owner and f"/{owner[c]}" in rec.topics]
    if len(cols) < len(OUTPUTS):
        res |= {"bit_exact": None, "signals_compared": cols, "max_abs_diff_by_signal": {},
                "first_mismatch_tick": None, "first_mismatch_signals": []}
        return res, out
    ref = rec.log[:, [names.index(c) for c in OUTPUTS]]
    same = out.view(np.uint64) == ref.view(np.uint64)
    with np.errstate(invalid="ignore"):
        diff = np.where(same, 0.0, np.abs(out - ref))
    diff = np.where(np.isnan(diff), np.inf, diff)
    bad = ~same.all(axis=1)
    first = int(np.argmax(bad)) if bad.any() else None
    res |= {"bit_exact": bool(same.all()), "signals_compared": list(OUTPUTS),
            "max_abs_diff_by_signal": {c: float(diff[:, j].max(initial=0.0)) for j, c in enumerate(OUTPUTS)},
            "first_mismatch_tick": int(rec.k[first]) if first is not None else None,
            "first_mismatch_signals": [OUTPUTS[j] for j in np.nonzero(~same[first])[0]] if first is not None else []}
    return res, out
