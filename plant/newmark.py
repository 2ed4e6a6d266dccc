"""The plant step: Newmark (average acceleration) on decoupled substructure modes with Newton
iterations on the contact gaps (SPEC section 2, "Time integration"). RT-safe, allocation-free.

Condensation. Each substructure's (Craig-Bampton reduced or full) linear part is diagonalised
once at design time: M = I, D = diag(c), K = diag(omega^2) in modal coordinates q, with
c = 2 zeta omega. Newmark with beta = 1/4, gamma = 1/2 and step h then reads, per mode,

    q_{n+1} = s (f_{n+1} + a0 q + a1 qd + qdd + c (a2 q + qd)) + s (G^T lambda)
            =            q_pred                             + s G^T lambda,
    s = 1 / (omega^2 + a2 c + a0),  a0 = 4/h^2, a1 = 4/h, a2 = 2/h,

and the contact gaps g = G q obey the small system of the contact pairs only

    g = g_pred + W lambda(g, w_n),      W = G diag(s) G^T   (2p x 2p, constant),

which Newton solves (Jacobian I - W dlambda/dg, dense LU with partial pivoting).

State vector x (see ``plant.model.state_slots``): q, qd, qdd (n each), slider w (p),
gaps g (2p), then E_fric, E_damp, W_exc, W_screw [J] and the inputs of the last step
F_exc_prev, F_N1_prev [N] (for the trapezoidal work).
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from plant.contact import _jenkins_pair

# reassociation (SIMD dot products) and FMA contraction only: NaN/Inf semantics are kept
FASTMATH = {"reassoc", "contract"}
N_ENERGY = 4        # E_fric, E_damp, W_exc, W_screw
N_TAIL = N_ENERGY + 2  # + F_exc_prev, F_N1_prev


class PlantParams(NamedTuple):
    """Constant arrays of the plant step (built by ``plant.model.build_plant``)."""
    c: np.ndarray          # (n,) 2 zeta omega [1/s]
    s: np.ndarray          # (n,) Newmark modal compliance [s^2]
    G: np.ndarray          # (2p, n) modal -> gaps (g_n, g_t interleaved) [m]
    GT: np.ndarray         # (n, 2p) its transpose, contiguous
    W: np.ndarray          # (2p, 2p) Delassus matrix G diag(s) G^T [m/N]
    b_exc: np.ndarray      # (n,) modal load of a unit excitation force
    b_N1: np.ndarray       # (n,) modal load of a unit adaptive screw force
    f_const: np.ndarray    # (n,) modal load of the constant screws [N]
    out_rows: np.ndarray   # (n_pts + 1, n) w at points, then u_rel
    k_n: np.ndarray        # (p,) [N/m]
    k_t: np.ndarray        # (p,) [N/m]
    mu: np.ndarray         # (p,) [-]
    h: float               # substep [s]
    substeps: int
    tol: float             # Newton tolerance on gaps [m]
    max_iter: int


class PlantWork(NamedTuple):
    """Scratch buffers of the plant step (preallocated once)."""
    q_pred: np.ndarray     # (n,)
    g_pred: np.ndarray     # (2p,)
    lam: np.ndarray        # (2p,)
    w_new: np.ndarray      # (p,)
    d: np.ndarray          # (3p,) dlambda_n/dg_n, dlambda_t/dg_n, dlambda_t/dg_t
    r: np.ndarray          # (2p,)
    LU: np.ndarray         # (2p, 2p) LU factors of the Newton Jacobian for `pattern`
    piv: np.ndarray        # (2p,) int64 row pivots of LU
    pattern: np.ndarray    # (p,) int64 contact state per pair the LU belongs to (-1: none yet)
    code: np.ndarray       # (p,) int64 contact state per pair of the current iterate


@numba.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _lu_factor(A, piv):
    """LU factorisation with partial pivoting in place (L unit lower, U upper). RT-safe."""
    n = A.shape[0]
    for k in range(n):
        p = k
        amax = abs(A[k, k])
        for i in range(k + 1, n):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        piv[k] = p
        if p != k:
            for j in range(n):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + 1, n):
            A[i, k] *= inv
            f = A[i, k]
            if f != 0.0:
                for j in range(k + 1, n):
                    A[i, j] -= f * A[k, j]


@numba.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _lu_solve(LU, piv, b):
    """Solve with the factors of ``_lu_factor``; b is overwritten by the solution. RT-safe."""
    n = LU.shape[0]
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(1, n):
        acc = b[i]
        for j in range(i):
            acc -= LU[i, j] * b[j]
        b[i] = acc
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= LU[i, j] * b[j]
        b[i] = acc / LU[i, i]


@numba.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _contact_newton(g, g_pred, w_old, p, wk):
    """Solve g = g_pred + W lambda(g, w_old) by Newton, starting from g (updated in place).

    The Jacobian I - W dlambda/dg depends only on each pair's state (open, stick, slip+,
    slip-), so its LU factors are kept with that pattern and reused while it holds: for the
    piecewise-linear contact law one solve then lands on the solution. On return wk.lam holds
    lambda and wk.w_new the slider positions. Returns the iterations used, or -1 if the
    tolerance was not reached within p.max_iter. RT-safe.
    """
    m = g.shape[0]
    npair = m // 2
    for it in range(p.max_iter):
        same = True
        for j in range(npair):
            ln, lt, wn, dnn, dtn, dtt = _jenkins_pair(g[2 * j], g[2 * j + 1], w_old[j],
                                                      p.k_n[j], p.k_t[j], p.mu[j])
            wk.lam[2 * j] = ln
            wk.lam[2 * j + 1] = lt
            wk.w_new[j] = wn
            wk.d[3 * j] = dnn
            wk.d[3 * j + 1] = dtn
            wk.d[3 * j + 2] = dtt
            c = 0 if dnn == 0.0 else (1 if dtn == 0.0 else (2 if dtn > 0.0 else 3))
            wk.code[j] = c
            same = same and c == wk.pattern[j]
        res = 0.0
        for i in range(m):
            acc = 0.0
            for k in range(m):
                acc += p.W[i, k] * wk.lam[k]
            ri = g[i] - g_pred[i] - acc
            wk.r[i] = -ri
            res = max(res, abs(ri))
        if res <= p.tol:
            return it
        if not same:
            # --- J = I - W dlambda/dg, dlambda/dg block diagonal [[dnn, 0], [dtn, dtt]] per pair
            for i in range(m):
                for j in range(npair):
                    wk.LU[i, 2 * j] = -(p.W[i, 2 * j] * wk.d[3 * j] + p.W[i, 2 * j + 1] * wk.d[3 * j + 1])
                    wk.LU[i, 2 * j + 1] = -p.W[i, 2 * j + 1] * wk.d[3 * j + 2]
                wk.LU[i, i] += 1.0
            _lu_factor(wk.LU, wk.piv)
            for j in range(npair):
                wk.pattern[j] = wk.code[j]
        _lu_solve(wk.LU, wk.piv, wk.r)
        for i in range(m):
            g[i] += wk.r[i]
    return -1


@numba.njit(cache=True, nogil=True, fastmath=FASTMATH)
def _plant_step(k, x, u, p, x_next, y, wk):
    """Advance the plant over one controller step (p.substeps Newmark substeps, inputs held).

    Parameters
    ----------
    k : int64 tick (the plant is time-invariant; kept for the uniform step signature)
    x : state at t_k (read only);  x_next : state at t_{k+1} (written)
    u : (2,) inputs held over the step: u[0] excitation force F_exc [N], u[1] F_N1 [N]
    p : PlantParams;  wk : PlantWork
    y : outputs at t_{k+1}, layout of ``plant.model.output_labels``: w, w', w'' at points
        [m, m/s, m/s^2]; u_rel [m], v_rel [m/s]; g_n, g_t [m], f_n, f_t [N] per pair;
        E_fric, E_damp, W_exc, W_screw [J]; Newton iterations (sum; -1 if any failed).

    Returns the Newton iterations summed over the substeps, or -1 if a solve did not converge.
    RT-safe.
    """
    n = p.c.shape[0]
    m = p.G.shape[0]
    npair = m // 2
    h = p.h
    a0 = 4.0 / (h * h)
    a1 = 4.0 / h
    a2 = 2.0 / h
    for i in range(x.shape[0]):
        x_next[i] = x[i]
    q = x_next[0:n]
    qd = x_next[n:2 * n]
    qdd = x_next[2 * n:3 * n]
    w = x_next[3 * n:3 * n + npair]
    g = x_next[3 * n + npair:3 * n + npair + m]
    e = 3 * n + npair + m
    F_exc, F_N1 = u[0], u[1]
    iters = 0
    for _ in range(p.substeps):
        # --- predictor: linear part with the contact forces off
        for i in range(n):
            f = p.b_exc[i] * F_exc + p.b_N1[i] * F_N1 + p.f_const[i]
            wk.q_pred[i] = p.s[i] * (f + a0 * q[i] + a1 * qd[i] + qdd[i] + p.c[i] * (a2 * q[i] + qd[i]))
        for r in range(m):
            acc = 0.0
            for i in range(n):
                acc += p.G[r, i] * wk.q_pred[i]
            wk.g_pred[r] = acc
        # --- contact: g = g_pred + W lambda(g)
        it = _contact_newton(g, wk.g_pred, w, p, wk)
        if it < 0 or iters < 0:
            iters = -1
        else:
            iters += it
        # --- corrector and energy bookkeeping
        dW_exc = 0.0
        dW_N1 = 0.0
        dW_const = 0.0
        dE_damp = 0.0
        for i in range(n):
            acc = 0.0
            for r in range(m):
                acc += p.GT[i, r] * wk.lam[r]
            q_new = wk.q_pred[i] + p.s[i] * acc
            dq = q_new - q[i]
            qdd_new = a0 * dq - a1 * qd[i] - qdd[i]
            qd_new = qd[i] + 0.5 * h * (qdd[i] + qdd_new)
            v_mid = 0.5 * (qd[i] + qd_new)
            dE_damp += h * p.c[i] * v_mid * v_mid
            dW_exc += p.b_exc[i] * dq
            dW_N1 += p.b_N1[i] * dq
            dW_const += p.f_const[i] * dq
            q[i] = q_new
            qd[i] = qd_new
            qdd[i] = qdd_new
        dE_fric = 0.0
        for j in range(npair):
            dE_fric += abs(wk.lam[2 * j + 1] * (wk.w_new[j] - w[j]))
            w[j] = wk.w_new[j]
        x_next[e] += dE_fric
        x_next[e + 1] += dE_damp
        x_next[e + 2] += 0.5 * (x_next[e + 4] + F_exc) * dW_exc
        x_next[e + 3] += 0.5 * (x_next[e + 5] + F_N1) * dW_N1 + dW_const
        x_next[e + 4] = F_exc
        x_next[e + 5] = F_N1
    # --- outputs
    n_rows = p.out_rows.shape[0]
    n_pts = n_rows - 1
    for r in range(n_rows):
        a_x = 0.0
        a_v = 0.0
        a_a = 0.0
        for i in range(n):
            a_x += p.out_rows[r, i] * q[i]
            a_v += p.out_rows[r, i] * qd[i]
            a_a += p.out_rows[r, i] * qdd[i]
        if r < n_pts:
            y[r] = a_x
            y[n_pts + r] = a_v
            y[2 * n_pts + r] = a_a
        else:
            y[3 * n_pts] = a_x
            y[3 * n_pts + 1] = a_v
    o = 3 * n_pts + 2
    for j in range(npair):
        y[o + j] = g[2 * j]
        y[o + npair + j] = g[2 * j + 1]
        y[o + 2 * npair + j] = wk.lam[2 * j]
        y[o + 3 * npair + j] = -wk.lam[2 * j + 1]
    o += 4 * npair
    for i in range(N_ENERGY):
        y[o + i] = x_next[e + i]
    y[o + N_ENERGY] = iters
    return iters
