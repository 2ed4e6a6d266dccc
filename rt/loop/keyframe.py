"""Key frames: the loop's state copied into the log at fixed tick multiples, so that a replay
restarts after a gap in the log (a dropped block of a paced run, the lost end of a killed one).

At the start of every tick k with k mod ``rt.keyframe_ticks`` = 0 (before stage 1: every state is
the one between ticks k - 1 and k, as ``Run.final`` holds it) the loop copies the parts below into
row (k / interval) mod R of a preallocated key-frame ring (``_keyframe_put``: no allocation, a
few hundred doubles); the log writer takes them out with the block that holds tick k and writes
them as messages of their own topic ``KEYFRAME_TOPIC`` (docs/data-format.md, "Key frames").
Because the ticks are fixed multiples, the file's bytes do not depend on how the ticks were split
into blocks.

Parts, in order (``keyframe_parts``; each a flat array of the loop's state, ``LoopState``):

    controller  sensors_x (the sensors' state; its tip integrator belongs to the controller),
                oracle_x, observer_x, law_x, law_y, prefilter_x, tracking_x, tracking_y,
                supervisor_x (its overrun flag: whether tick k - 1 overran)
    plant       actuator_x, actuator_y, plant_x, plant_y (the outputs at t_k: the oracle's
                u_rel, v_rel of tick k), shaker_x, and the contact solver's working vectors
                (``plant.newmark.PlantWork`` but its factor cache), and of the cache the
                ``PATTERNS`` (each kept slot's pattern of pair states and Jacobian entries, its
                key and last use, the current slot: ~3,100 values at the default mesh), from
                which the plant's replay refactorises the cache after a restart, bit for bit
    cache       (``rt.keyframe_plant_cache``) the rest of the contact solver's factor cache
                (``CACHE``, named cache_<field> in lower case): ~109,000 doubles at the default
                mesh, the factors themselves (a restart then needs no refactorisation)

float64 parts go to one ring, int64 parts (with the tick in column 0) to another.
"""
from __future__ import annotations

import numba
import numpy as np

from frictionrt.rt.log.keyframes import TOPIC as KEYFRAME_TOPIC  # noqa: F401  (the face)
CONTROLLER_PARTS = ("sensors_x", "oracle_x", "observer_x", "law_x", "law_y", "prefilter_x", "tracking_x",
                    "tracking_y", "supervisor_x")
PLANT_PARTS = ("actuator_x", "actuator_y", "plant_x", "plant_y", "shaker_x")
CACHE = ("LU", "Jinv", "piv", "pattern", "d_fact", "Z", "z_ok", "last_use", "key", "slot")
"""``PlantWork`` fields of the contact solver's factor cache (key-framed with rt.keyframe_plant_cache)."""
PATTERNS = ("pattern", "d_fact", "last_use", "key", "slot")
"""The part of ``CACHE`` every key frame carries (a few thousand values): what the factors are a
function of, so that a restart refactorises them bit for bit (``frictionrt.plant.newmark.refactor_kept``)."""


def keyframe_parts(st, cache: bool, patterns: bool = True) -> list[tuple[str, np.ndarray]]:
    """(name, flat view) of each key-frame part of the loop state ``st`` (module docstring);
    views, so that reading them reads the state and assigning into them sets it. ``patterns``:
    the cache's ``PATTERNS`` without the rest (False: the layout of logs written before they were
    key-framed, ``logged_patterns``)."""
    parts = [("sensors_x", st.xs), ("oracle_x", st.xo), ("observer_x", st.xe), ("law_x", st.xl), ("law_y", st.yl),
             ("prefilter_x", st.xq), ("tracking_x", st.xf), ("tracking_y", st.yf), ("supervisor_x", st.sv),
             ("actuator_x", st.xa), ("actuator_y", st.ya), ("plant_x", st.xp), ("plant_y", st.yp),
             ("shaker_x", st.xsh)]
    for name, a in st.plant_work._asdict().items():
        if cache or name not in CACHE or (patterns and name in PATTERNS):
            # ROS 2 field names are lower case: the cache's Z is cache_z, the working vector z work_z
            parts.append((("cache_" if name in CACHE else "work_") + name.lower(), a.reshape(-1)))
    return parts


def logged_patterns(keyframes) -> bool:
    """Whether a log's key frames (a read log's ``keyframes``, or None) carry the cache's
    ``PATTERNS`` (logs written before they did have the rest of the state only)."""
    return keyframes is None or any(p[0] == "cache_pattern" for p in keyframes.codec.parts)


def layout(parts) -> list[dict]:
    """The parts' description as the log records it: name, type (float64 or int64), size."""
    return [{"name": n, "type": "int64" if a.dtype == np.int64 else "float64", "size": int(a.size)} for n, a in parts]


def views(parts) -> tuple[tuple, tuple]:
    """(float64 parts, int64 parts) as tuples of 1-D arrays for ``_keyframe_put`` / ``_keyframe_load``."""
    return (tuple(a for _, a in parts if a.dtype != np.int64), tuple(a for _, a in parts if a.dtype == np.int64))


def widths(parts) -> tuple[int, int]:
    """(float64 columns, int64 columns incl. the tick) of a key-frame ring row."""
    f, i = views(parts)
    return sum(a.size for a in f), 1 + sum(a.size for a in i)


def ring_rows(ring_ticks: int, interval: int) -> int:
    """Rows of a key-frame ring beside a log ring of ring_ticks rows: a key frame's row is
    overwritten no earlier than its tick's row (R_kf * interval >= ring_ticks), plus one."""
    return -(-int(ring_ticks) // int(interval)) + 1


def no_keyframes(parts) -> tuple:
    """The key-frame argument of a run that writes none (interval 0)."""
    fv, iv = views(parts)
    return (0, np.zeros((1, 1)), np.zeros((1, 1), np.int64), fv, iv)


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _keyframe_put(k, kf):
    """At the start of tick k: if k is a multiple of the interval, the state's parts into the
    ring's row (k / interval) mod R, the tick into its int64 column 0. kf = (interval, float64
    ring, int64 ring, float64 parts, int64 parts). RT-safe."""
    interval, kf_f, kf_i, fv, iv = kf
    if interval <= 0 or k % interval != 0:
        return
    row = (k // interval) % kf_f.shape[0]
    c = 0
    for a in fv:
        for j in range(a.shape[0]):
            kf_f[row, c + j] = a[j]
        c += a.shape[0]
    kf_i[row, 0] = k
    c = 1
    for a in iv:
        for j in range(a.shape[0]):
            kf_i[row, c + j] = a[j]
        c += a.shape[0]


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _keyframe_load(f_row, i_row, fv, iv):
    """The state's parts from one key frame (f_row float64, i_row int64 with the tick in column
    0), the inverse of ``_keyframe_put``. RT-safe."""
    c = 0
    for a in fv:
        for j in range(a.shape[0]):
            a[j] = f_row[c + j]
        c += a.shape[0]
    c = 1
    for a in iv:
        for j in range(a.shape[0]):
            a[j] = i_row[c + j]
        c += a.shape[0]


def load(parts, f_row: np.ndarray, i_row: np.ndarray) -> None:
    """Set the state of ``parts`` from one key frame (Python; ``_keyframe_load``'s contract)."""
    fv, iv = views(parts)
    _keyframe_load(np.ascontiguousarray(f_row, dtype=np.float64), np.ascontiguousarray(i_row, dtype=np.int64), fv, iv)


def keyframe_codec(loop, st):
    """The key-frame encoding of runs of ``loop`` (``frictionrt.rt.log.keyframes.KeyframeCodec``: the
    interval rt.keyframe_ticks and the parts of ``st``, a state of the loop), or None when
    rt.keyframe_ticks is 0."""
    from frictionrt.rt.log.keyframes import KeyframeCodec
    interval = loop.cfg.rt.keyframe_ticks
    if interval <= 0:
        return None
    return KeyframeCodec.of(interval, layout(keyframe_parts(st, loop.cfg.rt.keyframe_plant_cache)))
