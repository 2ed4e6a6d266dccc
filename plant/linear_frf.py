"""The linear reference of the plant: its accelerance FRF with the preloaded contact stuck.

While no pair slips and no closed pair opens, the plant is linear. In the modal coordinates q
of the plant (mass-normalised, M = I), about the static equilibrium under the screws:

    q'' + C q' + K q = b_exc F_exc,
    K = diag(omega^2) + G^T K_c G      (``frictionrt.plant.model.stuck_stiffness``; k_n, k_t at the closed pairs)
    C = diag(2 zeta omega) + G^T C_c G (the interface dashpots c_n, s c_t of the closed pairs,
                                        s = S(min(1, penetration / depth)), plant.contact)

and the accelerance at output point j is

    H_j(Omega) = -Omega^2 r_j^T (K - Omega^2 I + i Omega C)^{-1} b_exc   [(m/s^2)/N].

The plant's step is the trapezoidal rule on this system (the quasi-static modes above
plant.quasi_static_hz: omega^2 (x1 + theta x0) / (1 + theta) equals the substep's mean load,
docs/plant.md 2.6):
per substep h, with the inputs held over the tick and the contact forces as means over the substep,

    v1 - v0 = h (b_exc F - C (v0 + v1)/2 - K (x0 + x1)/2),   x1 - x0 = h (v0 + v1)/2,

and its logged acceleration is the equation of motion at the end of the tick, with the modal
damping and the contact springs at the end point and the interface dashpots as their mean over
the last substep:

    a1 = r^T (b_exc F - C_m v1 - K x1 - C_c (x1 - x0') / h),   x0' the last substep's start.

``discrete_accelerance`` evaluates the steady-state response of exactly this map to the sampled
sine F_k = F e^{i omega k dt} (row k of a log: F_k and the output at t_{k+1}); it differs from the
continuous FRF by the trapezoidal rule's frequency warping, Omega = (2/h) tan(omega h / 2), and
by the half tick of the held force (at 380 Hz near mode 4: 4.7 %, measured). The step-sine of
the closed loop with the contact stuck equals it within the settling tolerance (tests).

Many lines at once (``modal_accelerance``, ``point_accelerances``: the FRF-file rig and
diagnosis). ``continuous_accelerance`` solves (K - w^2 I + i w C) x = b per line
(6385 lines, 86 modal DOFs: ~1 s); instead, the first-order form of the same linearised plant,

    z' = A z + B F,   A = [[0, I], [-K, -C]],   B = [0; b],   z = [q; q'],

is diagonalised once, A = V diag(lambda) V^-1, so that per line

    H(w) = -w^2 sum_j (r^T V_q[:, j]) (V^-1 B)_j / (i w - lambda_j)     [(m/s^2)/N]

(V_q the displacement rows of V): one eigen decomposition (~15 ms) and a (lines x 2n) sum.
Agrees with continuous_accelerance within 1e-7 relative (tests).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from frictionrt.plant.model import PlantModel, preloaded_pairs, stuck_stiffness


def stuck_damping(model: PlantModel, pairs: np.ndarray, penetration_m: np.ndarray) -> np.ndarray:
    """Modal damping matrix C [1/s] (module docstring) with the dashpots at the closed `pairs`
    weighted as the plant weights them at the static penetrations [m]."""
    p = model.params
    x = np.clip(penetration_m / p.dashpot_depth, 0.0, 1.0)
    s = x * x * (3.0 - 2.0 * x)
    c_all = np.zeros(p.G.shape[0])
    c_all[0::2] = p.c_n * pairs
    c_all[1::2] = p.c_t * pairs * s
    return np.diag(p.c) + (p.G.T * c_all) @ p.G


class StuckModel(NamedTuple):
    """The linearised plant (module docstring), modal coordinates, M = I."""
    K: np.ndarray      # (n, n) [1/s^2]
    C_m: np.ndarray    # (n, n) modal damping diag(2 zeta omega) [1/s]
    C_c: np.ndarray    # (n, n) interface dashpots G^T C_c G [1/s]
    b: np.ndarray      # (n,) modal load of a unit excitation force
    r: np.ndarray      # (n,) modal -> displacement at the output point
    dyn: np.ndarray    # (n,) 1 for a mode stepped by Newmark, 0 for a quasi-static one (PlantParams.dyn)
    omega2: np.ndarray  # (n,) omega^2 of the modes [1/s^2]
    theta: float       # the quasi-static modes' theta (PlantParams.qs_theta) [-]
    m_step: np.ndarray  # (n,) modal mass of the step (PlantParams.m_step; 1 unless period-matched) [-]
    c_step: np.ndarray  # (n,) modal damping of the step (PlantParams.c_step) [1/s]


def stuck_model(model: PlantModel, point: str, F_N1: float | None = None) -> StuckModel:
    """Linearise the plant about the static equilibrium at F_N1 [N] (default: the configured
    initial value) with the pairs the screws close stuck; output at the named point."""
    names = model.structure.point_names
    if point not in names:
        raise ValueError(f"point {point!r}: not an output point; the points are {', '.join(names)}")
    p = model.params
    x0 = model.initial_state(F_N1)
    pairs = preloaded_pairs(model, F_N1)
    C = stuck_damping(model, pairs, np.maximum(-x0[model.state_slots()["g"]][0::2], 0.0))
    C_m = np.diag(p.c)
    return StuckModel(K=stuck_stiffness(model, pairs), C_m=C_m, C_c=C - C_m, b=p.b_exc,
                      r=p.out_rows[names.index(point)], dyn=p.dyn.copy(), omega2=p.omega2.copy(),
                      theta=float(p.qs_theta), m_step=p.m_step.copy(), c_step=p.c_step.copy())


def continuous_accelerance(lin: StuckModel, freq_hz) -> np.ndarray:
    """H(omega) = -omega^2 r^T (K - omega^2 I + i omega C)^{-1} b [(m/s^2)/N] at freq_hz [Hz]."""
    eye = np.eye(len(lin.b))
    C = lin.C_m + lin.C_c
    out = []
    for w in 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, float)):
        out.append(-w * w * (lin.r @ np.linalg.solve(lin.K - w * w * eye + 1j * w * C, lin.b)))
    return np.array(out)


def _substep_maps(lin: StuckModel, dt: float, substeps: int):
    """(Phi_t, Gam_t, Phi, Gam): the tick's map s(t_k+1) = Phi_t s(t_k) + Gam_t F_k of the state
    s = [x, v] (trapezoidal substeps of h = dt / substeps, F held), and the map over its first
    substeps - 1 substeps."""
    n = len(lin.b)
    h = dt / substeps
    eye = np.eye(n)
    K, Cm, Cc, Mm = lin.K, np.diag(lin.c_step), lin.C_c, np.diag(lin.m_step)
    # dynamic modes: the trapezoid (the dashpots as C_c (x1 - x0) / h, their mean force);
    # quasi-static modes (docs/plant.md 2.6): omega^2 (x1 + theta x0) / (1 + theta) = b F + the
    # contact's mean force, v = 0
    Kc = K - np.diag(lin.omega2)
    M1 = np.block([[eye, -0.5 * h * eye], [0.5 * h * K + Cc, Mm + 0.5 * h * Cm]])
    M0 = np.block([[eye, 0.5 * h * eye], [-0.5 * h * K + Cc, Mm - 0.5 * h * Cm]])
    u = np.concatenate([np.zeros(n), h * lin.b])
    for i in np.flatnonzero(lin.dyn == 0):
        k_qs = lin.omega2[i] / (1.0 + lin.theta)
        M1[i] = np.concatenate([k_qs * eye[i] + 0.5 * Kc[i] + Cc[i] / h, np.zeros(n)])
        M0[i] = np.concatenate([-lin.theta * k_qs * eye[i] - 0.5 * Kc[i] + Cc[i] / h, np.zeros(n)])
        M1[n + i], M0[n + i] = np.concatenate([np.zeros(n), eye[i]]), 0.0
        u[i], u[n + i] = lin.b[i], 0.0
    Phi_s = np.linalg.solve(M1, M0)
    Gam_s = np.linalg.solve(M1, u)
    Phi, Gam = np.eye(2 * n), np.zeros(2 * n)     # over substeps - 1 substeps, then the last
    for _ in range(substeps - 1):
        Phi, Gam = Phi_s @ Phi, Phi_s @ Gam + Gam_s
    return Phi_s @ Phi, Phi_s @ Gam + Gam_s, Phi, Gam


def discrete_map(lin: StuckModel, dt: float, substeps: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, Gam) of the plant's tick with the contact stuck: s(t_k+1) = Phi s(t_k) + Gam F_k,
    s = [x, v] in modal coordinates, F_k [N] held over the tick (module docstring)."""
    Phi_t, Gam_t, _, _ = _substep_maps(lin, dt, substeps)
    return Phi_t, Gam_t


def discrete_accelerance(lin: StuckModel, freq_hz, dt: float, substeps: int = 1) -> np.ndarray:
    """The plant step's own FRF [(m/s^2)/N]: a(t_{k+1}) / F_k for F_k = e^{i omega k dt}, with
    substeps trapezoidal substeps of h = dt / substeps per tick (module docstring)."""
    n = len(lin.b)
    h = dt / substeps
    Phi_t, Gam_t, Phi, Gam = _substep_maps(lin, dt, substeps)
    out = []
    for w in 2 * np.pi * np.atleast_1d(np.asarray(freq_hz, float)):
        z = np.exp(1j * w * dt)
        s_k = np.linalg.solve(z * np.eye(2 * n) - Phi_t, Gam_t)   # state at t_k per unit F_k
        s_1 = z * s_k                                              # at t_{k+1}
        x_last = (Phi @ s_k + Gam)[:n]                             # at the last substep's start
        x1, v1 = s_1[:n], s_1[n:]
        a = (lin.b - lin.c_step * v1 - lin.K @ x1 - lin.C_c @ (x1 - x_last) / h) / lin.m_step
        out.append(lin.r @ (lin.dyn * a))   # a quasi-static mode has no acceleration
    return np.array(out)


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
