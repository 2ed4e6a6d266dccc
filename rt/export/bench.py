"""``frictionrt bench controller [--c DIR]``: the whole controller's time per tick, numba and C.

The controller of one tick as the exported C has it (rt/export/templates): the tip integrator
(``frictionrt.plant.sensors._tip_velocity``) and ``frictionrt.rt.loop.tick._controller_tick`` / ``_controller_done``:
estimator (the observer with its Newton step, or the oracle), law, supervisor, prefilter, force
tracking. ``bench loop``'s controller part leaves the observer and the supervisor out; this one
does not. Both run over the same readings, those of a closed-loop run of the configuration at
the budget's excitation (rt/loop/budget.py), and each tick is timed around the controller alone
(the clock's CLOCK_MONOTONIC, read inside the compiled loop for numba and inside ctrl_batch.c's
``ctrl_run_timed`` for the C). The C's outputs are compared with numba's bit for bit on the
way. With the C: the code and data size of the compiled object (``size``) and sizeof(ctrl_state).
"""
from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from frictionrt.rt.export.cbuild import BASE_FLAGS, build, compiler
from frictionrt.rt.export.generate import check_design
from frictionrt.rt.export.record import controller_record, design_hash
from frictionrt.rt.export.ticks import READINGS, SENSORS, closed_loop_readings, numba_outputs
from frictionrt.rt.loop.bench import _stats_us


def _size(folder: Path, cc) -> dict | None:
    """text, data, bss [bytes] of frictionrt_ctrl.c compiled at -O2 (None without ``size``)."""
    if shutil.which("size") is None:
        return None
    with tempfile.TemporaryDirectory(prefix="frictionrt-size-") as d:
        obj = Path(d) / "frictionrt_ctrl.o"
        subprocess.run([*compiler(cc).split(), BASE_FLAGS[0], "-O2", *BASE_FLAGS[1:], "-c", "-o", str(obj),
                        str(folder / "frictionrt_ctrl.c")], check=True, capture_output=True)
        text, data, bss = map(int, subprocess.run(["size", str(obj)], capture_output=True, text=True,
                                                  check=True).stdout.splitlines()[1].split()[:3])
    return {"text": text, "data": data, "bss": bss}


def bench_controller(loop, st, n_steps: int = 21000, folder=None, cc=None, manifest=None) -> dict:
    """Per-tick times of the controller of ``loop`` from ``st``: numba, and the C export in
    ``folder`` if given (it must be of this design: ValueError naming both hashes). JSON: law,
    estimator, ticks, numba -> median_us, p99_us, p999_us, max_us, mean_us; c -> the same,
    build, size {text, data, bss}, state_bytes, outputs_identical."""
    k, sens, uv = closed_loop_readings(loop, n_steps)
    numba_outputs(loop, st, k[:10], sens[:10], uv[:10])   # compile or load: not timed
    out, ns = numba_outputs(loop, st, k, sens, uv)
    res = {"law": loop.law, "estimator": loop.estimator, "ticks": int(len(k)), "numba": _stats_us(ns)}
    if folder is None:
        return res
    digest = design_hash(controller_record(loop, st))
    check_design(manifest, digest, loop, f"--c {folder}", "the benchmarked one",
                 "; give the same --config/--set, --law and --estimator")
    ctrl = build(folder, cc)
    r4 = np.ascontiguousarray(sens[:, [SENSORS.index(c) for c in READINGS]])
    ctrl.run_timed(k[:10], r4[:10], uv[:10])
    c_out, c_ns = ctrl.run_timed(k, r4, uv)
    res["c"] = _stats_us(c_ns) | {"build": " ".join(ctrl.command[:6]), "size": _size(Path(folder), cc),
                                   "state_bytes": ctrl.state_bytes(),
                                   "outputs_identical": bool((c_out.view(np.uint64) == out.view(np.uint64)).all())}
    return res


def format_bench(res: dict) -> str:
    """The figures as a table [us]."""
    lines = [f"controller per tick ({res['law']}, {res['estimator']}, {res['ticks']} ticks) [us]",
             f"  {'':<6}{'median':>9}{'p99':>9}{'p99.9':>9}{'max':>9}"]
    for name in ("numba", "c"):
        if name in res:
            s = res[name]
            lines.append(f"  {name:<6}{s['median_us']:>9.3f}{s['p99_us']:>9.3f}{s['p999_us']:>9.3f}{s['max_us']:>9.3f}")
    if "c" in res:
        c, size = res["c"], res["c"]["size"]
        lines.append(f"  C: {c['build']}; ctrl_state {c['state_bytes']} B; outputs "
                     f"{'identical to numba' if c['outputs_identical'] else 'DIFFER from numba'}")
        if size:
            lines.append(f"  object (size): {size['text']} B code and constants, {size['data']} B data, {size['bss']} B bss")
    return "\n".join(lines)
