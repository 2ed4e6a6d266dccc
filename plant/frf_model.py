"""The stuck plant's continuous accelerance on many frequency lines, fast (the FRF-file rig and
diagnosis, issue 7).

plant.linear_frf.continuous_accelerance solves (K - w^2 I + i w C) x = b per line (6385 lines,
86 modal DOFs: ~1 s). Here the first-order form of the same linearised plant,

    z' = A z + B F,   A = [[0, I], [-K, -C]],   B = [0; b],   z = [q; q'],

is diagonalised once, A = V diag(lambda) V^-1, so that per line

    H(w) = -w^2 sum_j (r^T V_q[:, j]) (V^-1 B)_j / (i w - lambda_j)     [(m/s^2)/N]

(V_q the displacement rows of V): one eigen decomposition (~15 ms) and a (lines x 2n) sum.
Agrees with continuous_accelerance within 1e-7 relative (tests).
"""
from __future__ import annotations

import numpy as np

from plant.linear_frf import StuckModel, stuck_model
from plant.model import PlantModel


def modal_accelerance(lin: StuckModel, freq_hz: np.ndarray, outputs: np.ndarray | None = None) -> np.ndarray:
    """H [(m/s^2)/N] at freq_hz [Hz] (module docstring); with ``outputs`` (m, n) the rows r of m
    output points instead of lin.r, giving (m, lines)."""
    n = len(lin.b)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-lin.K, -(lin.C_m + lin.C_c)]])
    lam, V = np.linalg.eig(A)
    q = np.linalg.solve(V, np.concatenate([np.zeros(n), lin.b]))
    R = np.atleast_2d(lin.r if outputs is None else outputs) @ V[:n]          # (m, 2n)
    w = 2 * np.pi * np.asarray(freq_hz, float)
    G = 1.0 / (1j * w[:, None] - lam[None, :])                               # (lines, 2n)
    H = -(w ** 2)[None, :] * ((R * q) @ G.T)
    return H[0] if outputs is None else H


def point_accelerances(model: PlantModel, points: dict[str, str], F_N1: float, freq_hz: np.ndarray) -> dict:
    """{name: H} of the stuck plant at F_N1 [N] for the named plant ``points`` {name: point}."""
    names = list(points)
    lin = stuck_model(model, points[names[0]], F_N1)
    rows = model.params.out_rows[[model.structure.point_names.index(points[s]) for s in names]]
    return dict(zip(names, modal_accelerance(lin, freq_hz, rows)))
