"""The offline step of an imported structure on its active contact set (design time: numpy and
LAPACK, not the tick).

The same Newmark step and contact law as plant.se_plant's kernel ``_se_step`` (its docstring has
the equations), solved in another way for interfaces of hundreds of points, where the kernel's
dense modified Newton on all m = p d gaps costs O(m^3 / 3) per refactorisation with an unblocked LU.

A point that is open at the start of the substep and at its end carries no force and has no
tangent (the normal penalty, both dashpots and the slider vanish for g_n >= 0), so its columns of
the Newton matrix J = I - W D are the identity's and its gaps follow linearly from the others'.
With A the points closed at the start or at the end (the active set) and O the rest:

    [ J_AA  0 ] [dg_A]   [r_A]       J_AA = I - W_AA D_A
    [ J_OA  I ] [dg_O] = [r_O],      g1_O = g_pred_O + W_OA Lambda_A

so the Newton iterates on the gaps of A only (a LAPACK LU of J_AA, kept while A and the
convergence allow, as the kernel keeps its factors: refreshed when a step is shortened or the
residual contracts by less than plant.se_plant.REFACTOR_RATIO), and O's gaps are set afterwards.
If one of O's points then closes, it joins A and the substep's Newton continues from there. The
result solves the kernel's equations to its tolerance (|r|_2 <= plant.newton_tol_m plus the same
round-off floor); it is not bitwise the kernel's (other summation order), so the two runs agree to
the Newton tolerance propagated, not to the bit.

Cost per substep: G q_pred over all m gaps (O(m n)), W_:A Lambda_A (O(m |A| d)) and per Newton
iteration O((|A| d)^2) plus a refactorisation of O((|A| d)^3 / 3) by LAPACK's blocked getrf.
"""
from __future__ import annotations

import numba
import numpy as np
import scipy.linalg as sla

from frictionrt.plant.newmark import ROUNDOFF
from frictionrt.plant.se_plant import LINE_SEARCH, N_ENERGY, REFACTOR_RATIO, SEPlant, _mean_forces


@numba.njit(cache=True, nogil=True)
def _jacobian_block(W, Db, J):
    """J = I - W blockdiag(Db) for W (k, k) and the blocks Db (k / d, d, d): (W D)[i, b d + j] =
    sum_c W[i, b d + c] Db[b, c, j]."""
    k = W.shape[0]
    nb, d = Db.shape[0], Db.shape[1]
    for i in range(k):
        for b in range(nb):
            for j in range(d):
                acc = 0.0
                for c in range(d):
                    acc += W[i, b * d + c] * Db[b, c, j]
                J[i, b * d + j] = (1.0 if i == b * d + j else 0.0) - acc


class ActiveSetStepper:
    """Steps an ``SEPlant`` as ``plant.se_plant._se_step`` does (same state x and outputs y), solving
    each substep's contact on its active set (module docstring). Not RT-safe: allocates, calls LAPACK.

    ``step(x, u, y)`` advances x in place by one controller step (u = (F_exc, F_N1) [N]) and fills y;
    returns the step's Newton iterations, or -1 if a substep failed to converge."""

    def __init__(self, plant: SEPlant):
        p = plant.params
        self.plant = plant
        self.p = p
        self.n = plant.n
        self.m = p.G.shape[0]
        self.d = 1 + p.nt
        self.npt = plant.n_points
        self.wk = plant.new_work()
        self.dyn = p.dyn > 0.0
        self.active = None       # bool (npt,): the active set of the kept factors
        self.lu = None
        self.gathers = 0         # how often the active set changed (its blocks gathered again)
        self.counts = np.zeros(2, dtype=np.int64)
        self.W_F = np.asfortranarray(p.W)        # column gathers of W are contiguous copies

    # --- the active set's blocks (gathered when the set changes)
    def _gather(self, active: np.ndarray):
        p, d = self.p, self.d
        pts = np.flatnonzero(active)
        idx = (pts[:, None] * d + np.arange(d)).ravel()
        self.active = active.copy()
        self.idx = idx
        self.nb = len(pts)
        self.W_A = self.W_F[:, idx]                       # (m, k), Fortran order: W's columns of A
        self.W_AA = np.ascontiguousarray(self.W_A[idx])
        self.absW_AA = np.abs(self.W_AA)
        self.G_A = np.ascontiguousarray(p.G[idx])         # (k, n)
        self.lu = None
        self.gathers += 1

    def _residual(self, g1, g_pred):
        wk, idx = self.wk, self.idx
        lam = wk.lam[idx]
        r = g1[idx] - g_pred[idx] - self.W_AA @ lam
        mag = np.abs(g1[idx]) + np.abs(g_pred[idx]) + self.absW_AA @ np.abs(lam)
        floor = ROUNDOFF * (mag.max() if len(mag) else 0.0) * np.sqrt(self.m)
        return r, float(np.sqrt(r @ r)), floor

    def _factor(self):
        nb, d = self.nb, self.d
        k = nb * d
        Db = self.wk.D.reshape(self.npt, d, d)[self.active]               # (nb, d, d) dLambda/dg1
        J = np.empty((k, k))
        _jacobian_block(self.W_AA, np.ascontiguousarray(Db), J)
        self.lu = sla.lu_factor(J, overwrite_a=True, check_finite=False)

    def _substep(self, q, qd, w, g, en, F_exc, F_N1) -> int:
        p, wk, d, nt = self.p, self.wk, self.d, self.p.nt
        h = p.h
        f = p.b_exc * F_exc + p.b_N1 * F_N1 + p.f_const
        q_pred = np.where(self.dyn, q + p.s2 * (f + 2.0 / h * qd - p.omega2 * q), p.s2 * f - p.qs_theta * q)
        g_pred = p.G @ q_pred + p.gap0
        closed0 = g[0::d] < 0.0
        wk.lam0[:] = 0.0
        for a in range(nt):
            wk.lam0[1 + a::d] = np.where(closed0, -p.k_t * (g[1 + a::d] - w[a::nt]), 0.0)
        # --- initial guess as the kernel's: the previous gaps moved by the predictor's change
        g1 = g.copy()
        _mean_forces(g, g1, w, p, wk, False)
        if not closed0.any():
            g1[:] = g_pred
        elif self.active is not None and not np.any(closed0 & ~self.active):
            g1[:] = g_pred + self.W_A @ wk.lam[self.idx]     # Lambda vanishes outside closed0
        else:
            g1[:] = g_pred + p.W @ wk.lam
        active = closed0 | (g1[0::d] < 0.0)
        if self.active is None or not np.array_equal(active, self.active):
            self._gather(active)
        it = refac = 0
        converged = False
        while True:
            idx = self.idx
            e_fric = _mean_forces(g, g1, w, p, wk, True)
            r, rn, floor = self._residual(g1, g_pred)
            stale = self.lu is None
            while it < p.max_iter:
                if rn <= p.tol + floor:
                    converged = True
                    break
                if stale:
                    self._factor()
                    refac += 1
                dg = sla.lu_solve(self.lu, r, check_finite=False)
                g_old = g1[idx].copy()
                alpha = 1.0
                rn_new = rn
                for _ls in range(LINE_SEARCH):
                    g1[idx] = g_old - alpha * dg
                    e_fric = _mean_forces(g, g1, w, p, wk, True)
                    r, rn_new, floor = self._residual(g1, g_pred)
                    if rn_new <= (1.0 - 1e-4 * alpha) * rn or rn_new <= p.tol + floor:
                        break
                    alpha *= 0.5
                stale = alpha < 1.0 or rn_new > REFACTOR_RATIO * rn
                rn = rn_new
                it += 1
            if not converged:
                break
            # --- the open points' gaps from A's forces; a point that closes joins A
            g_all = g_pred + self.W_A @ wk.lam[idx]
            rest = ~self.active
            closing = rest & (g_all[0::d] < 0.0)
            out = np.repeat(rest, d)
            g1[out] = g_all[out]
            if not closing.any():
                e_fric = _mean_forces(g, g1, w, p, wk, False)   # the open points' sliders at g1
                break
            self._gather(self.active | closing)
            converged = False
        self.counts += (it, refac)
        if not converged:
            return -1
        # --- update: q1 = q_pred + s2 G^T Lambda, qd1 = 2 dq / h - qd0
        f_c = self.G_A.T @ wk.lam[self.idx]
        q1 = q_pred + p.s2 * f_c
        dq = q1 - q
        qd1 = (2.0 * dq / h - qd) * p.dyn
        en[0] += e_fric
        en[1] += float(np.sum(p.c * 0.25 * (qd + qd1) ** 2 * h))
        en[2] += float(p.b_exc @ dq) * F_exc
        en[3] += float(p.b_N1 @ dq) * F_N1
        q[:] = q1
        qd[:] = qd1
        g[:] = g1
        w[:] = wk.w_new
        return it

    def step(self, x: np.ndarray, u, y: np.ndarray) -> int:
        p, n, m = self.p, self.n, self.m
        nw = self.npt * p.nt
        x_start_qd = x[n:2 * n].copy()
        q, qd = x[0:n], x[n:2 * n]
        w, g = x[2 * n:2 * n + nw], x[2 * n + nw:2 * n + nw + m]
        en = x[2 * n + nw + m:2 * n + nw + m + N_ENERGY]
        self.counts[:] = 0
        its = failed = 0
        for _ in range(p.substeps):
            it = self._substep(q, qd, w, g, en, float(u[0]), float(u[1]))
            if it < 0:
                failed += 1
            else:
                its += it
        # --- outputs as _se_step's
        lam = np.zeros(m)
        lam[self.idx] = self.wk.lam[self.idx]
        qdd = (p.b_exc * u[0] + p.b_N1 * u[1] + p.f_const - p.c * qd - p.omega2 * q + p.G.T @ lam) * p.dyn
        ns = p.S.shape[0] - 1
        yq, yv, ya = p.S @ q, p.S @ qd, p.S @ qdd
        y[0:ns], y[ns:2 * ns], y[2 * ns:3 * ns] = yq[:ns], yv[:ns], ya[:ns]
        y[3 * ns], y[3 * ns + 1] = yq[ns], yv[ns]
        sep = float(p.bolt_row @ q)
        o = 3 * ns + 2
        y[o] = u[1] + p.bolt_k * (sep - p.bolt_ref)
        y[o + 1:o + 1 + N_ENERGY] = en
        y[o + 5], y[o + 6], y[o + 7] = self.counts[0], self.counts[1], failed
        y[o + 8:o + 8 + ns] = (p.S[:ns] @ (qd - x_start_qd)) / (p.h * p.substeps)
        y[o + 8 + ns] = p.bolt_k * (sep - p.bolt_ref)
        return -1 if failed else its


def run_active_set(plant: SEPlant, U: np.ndarray, x0: np.ndarray, Y: np.ndarray | None = None):
    """Simulate len(U) controller steps (U[k] = (F_exc, F_N1) [N]) from x0 with ``ActiveSetStepper``;
    returns (Y, x_final, failed steps)."""
    st = ActiveSetStepper(plant)
    x = np.array(x0, dtype=np.float64)
    if Y is None:
        Y = np.zeros((len(U), len(plant.output_labels())))
    failed = 0
    for k in range(len(U)):
        if st.step(x, U[k], Y[k]) < 0:
            failed += 1
    return Y, x, failed
