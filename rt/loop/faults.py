"""Fault injection (``frictionrt simulate --fault``, docs/reliability.md): the ``--fault`` strings,
the schedule array the loop's kernels read (``frictionrt.rt.loop.supervisor``), and what the supervisor made of
each injected fault (from the log).

Syntax: ``KIND[/SENSOR][=VALUE]@TIME[:DURATION]`` with TIME, DURATION in s (no DURATION: to the
end of the run). Kinds and their VALUE (default in brackets):

    sensor_dropout     the reading is NaN                                      (-)
    sensor_stuck       the reading keeps its value of the tick before          (-)
    sensor_gain        reading x VALUE, through the ADC again                  [10]
    sensor_bias        reading + VALUE [m/s^2 or N], through the ADC again     [10 % of full scale]
    actuator_loss      amplifier off: 0 V at its input                         (-)
    force_saturation   the stack's force capped at VALUE [N] (amplifier input
                       limited to (VALUE - F0) / c_v)                          [100 N]
    observer_mismatch  the observer's tip-velocity input x VALUE (its model's   [50]
                       tip mode shapes off by that factor)
    cpu_stall          a busy delay of VALUE [us] in every tick (paced runs)   [60 us]

SENSOR (sensor kinds only): a_tip (default: the tip accelerometer, the observer's input),
a_frf, F_strain, F_cell.
"""
from __future__ import annotations

import re

import numpy as np

from frictionrt.plant.sensors import output_index
from frictionrt.rt.loop.supervisor import (F_END, F_KIND, F_START, F_TARGET, F_VALUE, FAULT_CODES, FAULT_KINDS, K_BIAS,
                           K_CPU_STALL, K_FORCE_SAT, K_GAIN, K_OBS_MISMATCH)

SENSOR_KINDS = FAULT_KINDS[:4]
SENSOR_NAMES = {"a_tip": "a_tip_meas", "a_frf": "a_frf_meas", "F_strain": "F_strain", "F_cell": "F_cell"}
NO_END = float(2**62)  # k_end of a fault without a duration
SYNTAX = "KIND[/SENSOR][=VALUE]@TIME[:DURATION] (TIME, DURATION in s), e.g. sensor_dropout@0.2:0.05"
_RX = re.compile(r"(?P<kind>\w+)(?:/(?P<sensor>\w+))?(?:=(?P<value>[^@]+))?@(?P<time>[^:]+)(?::(?P<dur>.+))?\Z")


def _default_value(kind: int, sensor: str, cfg) -> float:
    if kind == K_GAIN:
        return 10.0
    if kind == K_BIAS:
        return 0.1 * (cfg.sensors.acc_range if sensor.startswith("a_") else cfg.sensors.force_range_N)
    if kind == K_FORCE_SAT:
        return 100.0
    if kind == K_OBS_MISMATCH:
        return 50.0
    if kind == K_CPU_STALL:
        return 60.0
    return 0.0


def parse(text: str, cfg) -> np.ndarray:
    """One ``--fault`` string -> a schedule row (kind, target, k_start, k_end, value).

    ValueError naming the value and the fix for a bad string."""
    bad = f"--fault {text!r}"
    m = _RX.match(text.strip())
    if not m:
        raise ValueError(f"{bad}: expected {SYNTAX}")
    name = m["kind"]
    if name not in FAULT_KINDS:
        raise ValueError(f"{bad}: unknown kind {name!r}; kinds: {', '.join(FAULT_KINDS)}")
    kind = FAULT_KINDS.index(name)
    sensor = m["sensor"]
    if sensor is not None and name not in SENSOR_KINDS:
        raise ValueError(f"{bad}: only the sensor kinds ({', '.join(SENSOR_KINDS)}) name a sensor; drop /{sensor}")
    sensor = sensor or "a_tip"
    if sensor not in SENSOR_NAMES:
        raise ValueError(f"{bad}: unknown sensor {sensor!r}; sensors: {', '.join(SENSOR_NAMES)}")
    try:
        t = float(m["time"])
        dur = None if m["dur"] is None else float(m["dur"])
        value = _default_value(kind, sensor, cfg) if m["value"] is None else float(m["value"])
    except ValueError:
        raise ValueError(f"{bad}: TIME, DURATION and VALUE must be numbers; expected {SYNTAX}") from None
    if not (np.isfinite(t) and t >= 0.0):
        raise ValueError(f"{bad}: TIME {m['time']} must be a time >= 0 s")
    if dur is not None and not (np.isfinite(dur) and dur > 0.0):
        raise ValueError(f"{bad}: DURATION {m['dur']} must be a time > 0 s (or leave it out: to the end)")
    if not np.isfinite(value):
        raise ValueError(f"{bad}: VALUE {m['value']} must be a finite number")
    if kind == K_CPU_STALL and not 0.0 < value <= 1e5:
        raise ValueError(f"{bad}: the stall VALUE {value:g} us must lie in (0, 1e5] us")
    dt = cfg.dt_s
    k0 = int(round(t / dt))
    k1 = NO_END if dur is None else k0 + max(1, int(round(dur / dt)))
    a = cfg.actuator
    if kind == K_FORCE_SAT:
        value = (value - a.F0_N) / a.c_v  # the amplifier input cap [V]
    elif kind == K_CPU_STALL:
        value = round(value * 1e3)  # [ns]
    row = np.zeros(5)
    row[F_KIND], row[F_TARGET], row[F_START], row[F_END], row[F_VALUE] = (
        kind, output_index()[SENSOR_NAMES[sensor]], k0, k1, value)
    return row


def schedule(texts, cfg) -> np.ndarray:
    """The schedule (n, 5) of the ``--fault`` strings (``parse``), in their order."""
    rows = [parse(t, cfg) for t in texts]
    return np.array(rows) if rows else np.zeros((0, 5))


def to_json(faults: np.ndarray) -> list[dict]:
    """The schedule as JSON-able rows (stored in the run's metadata; ``from_json`` reads it back)."""
    return [{"kind": FAULT_KINDS[int(f[F_KIND])], "target": int(f[F_TARGET]), "k_start": int(f[F_START]),
             "k_end": int(f[F_END]), "value": float(f[F_VALUE])} for f in faults]


def from_json(rows: list[dict]) -> np.ndarray:
    """The schedule of ``to_json`` rows. ValueError for rows that are not such (a corrupt or
    edited log): an unknown kind, a target that is no sensor (the kernels index with it), ticks
    not 0 <= k_start < k_end, a value that is not finite."""
    if not isinstance(rows, list):
        raise ValueError(f"expected a list of faults, got {type(rows).__name__}")
    n_sensors = len(output_index())
    out = np.zeros((len(rows), 5))
    for i, r in enumerate(rows):
        try:
            row = (FAULT_KINDS.index(r["kind"]), r["target"], r["k_start"], r["k_end"], float(r["value"]))
        except (TypeError, KeyError, ValueError):
            raise ValueError(f"fault {i}: expected {{kind, target, k_start, k_end, value}} with a known kind, "
                             f"got {str(r)[:80]}") from None
        kind, target, k0, k1, value = row
        if not (all(type(v) is int for v in (target, k0, k1)) and 0 <= target < n_sensors and 0 <= k0 < k1
                and np.isfinite(value)):
            raise ValueError(f"fault {i}: target, ticks or value out of range: {str(r)[:80]}")
        out[i] = row
    return out


def outcome(log_k: np.ndarray, code: np.ndarray, passive: np.ndarray, faults: np.ndarray, grace: int) -> list[dict]:
    """Per injected fault: kind, sensor, tick (injected), code and name (the first fault code
    the supervisor logged from that tick until ``grace`` ticks after the fault's end),
    detected_tick (None: not detected), passive_tick (first passive tick from there)."""
    names = {v: k for k, v in output_index().items()}
    out = []
    for f in faults:
        k0, k1 = int(f[F_START]), int(f[F_END])
        kind = int(f[F_KIND])
        win = (log_k >= k0) & (log_k < min(k1, NO_END - grace) + grace) & (code != 0)
        d = {"kind": FAULT_KINDS[kind], "sensor": names[int(f[F_TARGET])] if FAULT_KINDS[kind] in SENSOR_KINDS else None,
             "tick": k0, "code": None, "name": None, "detected_tick": None, "passive_tick": None}
        if win.any():
            i = int(np.argmax(win))
            c = int(code[i])
            p = np.nonzero((passive != 0) & (log_k >= log_k[i]))[0]
            d |= {"code": c, "name": FAULT_CODES[c], "detected_tick": int(log_k[i]),
                  "passive_tick": int(log_k[p[0]]) if len(p) else None}
        out.append(d)
    return out


def trips(log_k: np.ndarray, latched: np.ndarray) -> list[dict]:
    """Every latch of the run: code, name, tick; recovered_tick (auto recovery) or None."""
    change = np.nonzero(np.diff(np.r_[0.0, latched]) != 0)[0]
    out = []
    for i in change:
        if latched[i] != 0:
            out.append({"code": int(latched[i]), "name": FAULT_CODES[int(latched[i])], "tick": int(log_k[i]),
                        "recovered_tick": None})
        elif out:
            out[-1]["recovered_tick"] = int(log_k[i])
    return out
