"""Golden vectors of an export: a sensor stream and the controller's expected outputs as raw IEEE
bits, so that a target build is proven without Python (``make check`` in the export folder).

``golden_vectors(loop, state)`` makes the stream from the design's own simulation: the readings of
a closed-loop run of ``TICKS`` ticks at ``FREQ_HZ``, ``AMP_N`` (mode 3's resonance at an amplitude
that lifts the hysteresis law above F_min and the Lyapunov law to F_max), with two edits that
engage the supervisor: a tip-accelerometer dropout (NaN readings: the sanitiser, fault 1) and then
a force-cell reading of 0 N (a range fault: the passive fallback, latched). The expected outputs
are the numba controller's (``frictionrt.rt.export.ticks.numba_outputs``) from the export's state
at rest. Its coverage (``frictionrt.rt.loop.coverage``) goes into the manifest.

Files (``write_golden``), one tick per line, every number a hexadecimal integer (the bits of the
IEEE 754 binary64 value; k and overran as integers), so a C library without hexadecimal floating
input or output (newlib) reads them with ``strtoull`` alone:

    golden_in.txt    k a_tip_meas a_frf_meas F_strain F_cell overran [u_rel v_rel]   (oracle build: u_rel, v_rel)
    golden_out.txt   the 13 outputs in ctrl_outputs order

Lines starting with '#' are comments; the first line of each names the design hash.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionrt.rt.export.ticks import SENSORS, closed_loop_readings, numba_outputs
from frictionrt.rt.export.cbuild import OUTPUTS
from frictionrt.rt.loop.coverage import coverage

TICKS = 3150            # 0.15 s at 21 kHz
FREQ_HZ, AMP_N = 223.6, 20.0
DROPOUT = (0.40, 0.41)  # fraction of the stream: a_tip_meas NaN
RANGE = (0.70, 0.72)    # F_cell = 0 N: a range fault, the passive fallback
INPUTS = ("k", "a_tip_meas", "a_frf_meas", "F_strain", "F_cell", "overran")


def golden_vectors(loop, state) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(k (n,), readings (n, 5) in ``SENSORS`` order, uv (n, 2), outputs (n, 13)) of the golden
    stream (module docstring)."""
    k, sens, uv = closed_loop_readings(loop, TICKS, FREQ_HZ, AMP_N)
    n = len(k)
    sens = sens.copy()
    a, b = (int(f * n) for f in DROPOUT)
    sens[a:b, SENSORS.index("a_tip_meas")] = np.nan
    a, b = (int(f * n) for f in RANGE)
    sens[a:b, SENSORS.index("F_cell")] = 0.0
    out, _ = numba_outputs(loop, state, k, sens, uv)
    return k, sens, uv, out


def _hex(a: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(a, dtype="<f8").view("<u8")


def write_golden(folder: Path, loop, state, digest: str) -> dict:
    """golden_in.txt and golden_out.txt into folder (module docstring); returns the coverage."""
    k, sens, uv, out = golden_vectors(loop, state)
    observe = loop.observes
    cols = [sens[:, SENSORS.index(c)] for c in INPUTS[1:5]]
    bits = [_hex(c) for c in cols]
    if not observe:
        bits += [_hex(uv[:, 0]), _hex(uv[:, 1])]
    head = (f"# frictionrt golden {digest}\n# {' '.join(INPUTS + (() if observe else ('u_rel', 'v_rel')))}"
            " (hexadecimal: k, the IEEE 754 bits of each reading, overran)\n")
    rows = [f"{int(k[i]):x} " + " ".join(f"{b[i]:x}" for b in bits[:4]) + " 0"
            + ("" if observe else " " + " ".join(f"{b[i]:x}" for b in bits[4:])) for i in range(len(k))]
    (folder / "golden_in.txt").write_text(head + "\n".join(rows) + "\n")
    ob = _hex(out)
    head = f"# frictionrt golden {digest}\n# {' '.join(OUTPUTS)} (the IEEE 754 bits)\n"
    (folder / "golden_out.txt").write_text(head + "\n".join(" ".join(f"{v:x}" for v in row) for row in ob) + "\n")
    return coverage(loop.law, loop.cfg.tracking.F_min_N, loop.cfg.tracking.F_max_N,
                    {c: out[:, j] for j, c in enumerate(OUTPUTS)})
