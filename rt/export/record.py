"""The controller's design record: every number the exported C controller reads, and its hash.

``controller_record(loop, state)`` selects, from the arrays a run log carries
(``frictionrt.rt.log.design_record.design_arrays``: the kernels' parameter tuples and the initial state),
exactly what the controller tick uses (rt/loop/tick.py ``_controller_tick``, the tip integrator
of plant/sensors.py ``_tip_velocity``):

    tip.F1                  the tip integrator's row of SensorParams.F1 (3,)
    oracle.* | observer.*   the estimator's parameters (the one the loop runs)
    law.*, prefilter.*, tracking.*, supervisor.*   the other stages' parameters
    state.xs                the integrator's slots (v_tip, previous a_tip_meas) at the start
    state.xo | state.xe, state.xl, state.xq, state.xf, state.sv   the other initial states
    export.observe, export.force_col   the estimator and the reading the force tracking uses

``design_hash(record)`` is the SHA-256 of its canonical bytes: for each key in sorted order the
key, the array's dtype and shape, and its little-endian C-order bytes (no compression, so the
same numbers give the same hash with any zlib). A log and an export of the same design carry the
same hash; a change of any controller number changes it, a change of the plant does not.
"""
from __future__ import annotations

import hashlib

import numpy as np

from frictionrt.plant.sensors import output_index
from frictionrt.rt.log.design_record import design_arrays

STAGES = ("law", "prefilter", "tracking", "supervisor")
TIP_SLOTS = slice(6, 8)  # plant.sensors.SENSOR_SLOTS v_tip, a_tip_meas_in


def controller_record(loop, state) -> dict[str, np.ndarray]:
    """The controller's numbers of ``loop`` started from ``state`` (module docstring); the
    amplitude-following observer's blocks as "amplitude.*" (its design hash; the C templates do
    not hold that kind, ``export_c`` refuses it)."""
    arrays = design_arrays(loop, state)
    observe = loop.observes
    est = "observer" if observe else "oracle"
    rec = {"tip.F1": np.ascontiguousarray(arrays["params.sensors.F1"][0])}
    for key, a in arrays.items():
        part = key.split(".")[1] if key.startswith("params.") else None
        if part == est or part in STAGES:
            rec[key[len("params."):]] = a
    rec["state.xs"] = np.ascontiguousarray(arrays["state.xs"][TIP_SLOTS])
    for slot in ("xe" if observe else "xo", "xl", "xq", "xf", "sv"):
        rec[f"state.{slot}"] = arrays[f"state.{slot}"]
    if loop.estimator == "amplitude":
        for name, a in loop.amplitude._asdict().items():
            rec[f"amplitude.{name}"] = np.ascontiguousarray(a)
    rec["export.observe"] = np.array(observe)
    rec["export.force_col"] = np.array(output_index()["F_strain" if loop.force_sensor == "strain" else "F_cell"],
                                       dtype=np.int64)
    return {k: rec[k] for k in sorted(rec)}


def design_hash(record: dict[str, np.ndarray]) -> str:
    """"sha256:<hex>" of the record's canonical bytes (module docstring)."""
    h = hashlib.sha256()
    for key in sorted(record):
        a = np.ascontiguousarray(record[key])
        a = a.astype(a.dtype.newbyteorder("<"), copy=False)
        h.update(f"{key}\0{a.dtype.str}\0{list(a.shape)}\0".encode())
        h.update(a.tobytes())
    return "sha256:" + h.hexdigest()
