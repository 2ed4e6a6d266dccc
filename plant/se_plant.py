"""An imported structure (plant.superelement) as a plant: design-time build and the step kernel.

Design time (``build_se_plant``): the superelement's M, K plus the adaptive bolt's spring are
diagonalised once (M-normalised modes Phi, omega), the interface rows become G = R Phi (m = p d
gaps, d = 1 + nt), and the Newmark constants are those of plant.newmark (average acceleration,
mean form, m = 1 per mode):

    q1 = q_pred + s2 G^T Lambda,   q_pred = q0 + s2 (f + (2/h) qd0 - omega^2 q0),
    s2 = 2 / (omega^2 + 2 c / h + 4 / h^2),      g1 = g_pred + W Lambda(g0, g1),  W = G diag(s2) G^T

Run time (``_se_step``, RT-safe, allocation-free): Lambda per point is the normal spring's
discrete gradient (plant.contact._normal_impulse), the trapezoid of the tangential end forces of
the circular-Coulomb law (plant.contact3d._coulomb_disc) and the dashpots
(plant.contact._interface_dashpot); the gaps are found by a modified Newton iteration from the
previous step's gaps: the LU factors of J = I - W dLambda/dg1 are kept from step to step and
refreshed only when an iteration contracts the residual by less than REFACTOR_RATIO (a stuck or
slowly changing interface costs one substitution per iteration, O(m^2); a refresh costs
O(m^3 / 3)). After a rejected full step the line search first tries the step to the first branch
change of the end-point law along the Newton direction (``_first_kink``; open/closed, stick/slip),
just past it, so that the next iteration has the tangent of the side the solution lies on; then
halving. A kink step is taken without a decrease
of |r|, but not twice in a row without a 1 % decrease (KINK_PROGRESS).

The built-in 2-D plant keeps its own kernel (plant.newmark); this one serves imported structures
with 2-D (nt = 2, circular limit) or 1-D (nt = 1) friction.

Length: the kernel, its Newton and the design-time build that fills its arrays (including the
static equilibrium that sets the bolt's reference) are one unit, as plant.newmark and plant.model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
import scipy.linalg as sla

from frictionrt.plant.contact import _interface_dashpot, _normal_impulse
from frictionrt.plant.contact3d import FASTMATH, _coulomb_disc
from frictionrt.plant.newmark import ROUNDOFF, _lu_factor, _lu_solve
from frictionrt.plant.superelement import Superelement

LINE_SEARCH = 30       # halvings of a Newton step before it is taken as it is
KINK_PAST = 1e-6      # the kink step goes this fraction of itself (plus 1e-9 of the Newton step) past the branch change
KINK_PROGRESS = 0.99  # a kink step that leaves |r| above this fraction of itself is not followed by another
REFACTOR_RATIO = 1e-2   # refresh the Jacobian's factors when |r_new| > ratio |r_old| (a kept factor of the
                        # right contact pattern solves the piecewise-linear step in one iteration)
RIGID_BODY_RAD_S = 2 * np.pi * 0.1
N_ENERGY = 4            # E_fric, E_damp, W_exc, W_bolt


class SEParams(NamedTuple):
    """Constant arrays of the superelement step."""
    omega2: np.ndarray    # (n,) [1/s^2]
    dyn: np.ndarray       # (n,) 1.0 stepped by Newmark, 0.0 quasi-static (no inertia)
    qs_theta: float       # quasi-static modes: q1 = (1 + theta) q_static - theta q0 [-]
    c: np.ndarray         # (n,) modal damping [1/s]
    s2: np.ndarray        # (n,) [s^2]
    G: np.ndarray         # (m, n) modal -> gaps [m]
    gap0: np.ndarray      # (m,) gaps at q = 0 [m]
    W: np.ndarray         # (m, m) [m/N]
    b_exc: np.ndarray     # (n,)
    b_N1: np.ndarray      # (n,) modal load of a unit adaptive-bolt force (-Phi^T r_b)
    f_const: np.ndarray   # (n,) ordinary bolts' preload and the adaptive bolt's k_b s_ref [N]
    S: np.ndarray         # (s + 1, n) sensors' displacement rows, then u_rel
    bolt_row: np.ndarray  # (n,) separation at the adaptive bolt [m]
    bolt_k: float         # [N/m]
    bolt_ref: float       # [m]
    k_n: np.ndarray       # (p,) [N/m]
    k_t: np.ndarray       # (p,) [N/m]
    mu: np.ndarray        # (p,) [-]
    cn_h: np.ndarray      # (p,) c_n / h [N/m]
    ct_h: np.ndarray      # (p,) c_t / h [N/m]
    depth: float          # [m]
    nt: int               # tangential directions per point (1 or 2)
    h: float              # substep [s]
    substeps: int
    tol: float            # [m]
    max_iter: int


class SEWork(NamedTuple):
    q_pred: np.ndarray
    f_c: np.ndarray
    qdd: np.ndarray
    g_pred: np.ndarray
    g1: np.ndarray
    lam: np.ndarray        # (m,) mean force Lambda
    lam1: np.ndarray       # (m,) end-point spring/slider force
    lam0: np.ndarray       # (m,) start-point tangential force
    w_new: np.ndarray
    D: np.ndarray          # (p d^2,) point tangents
    r: np.ndarray
    dg: np.ndarray         # (m,) Newton step
    g_old: np.ndarray      # (m,) gaps before the step
    LU: np.ndarray         # (m, m)
    piv: np.ndarray
    have_lu: np.ndarray    # (1,) int64: 1 if LU holds factors
    counts: np.ndarray     # (2,) int64: Newton iterations, refactorisations of the last step


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _mean_forces(g0, g1, w_old, p, wk, with_tangent):
    """Lambda (mean over the step) into wk.lam, end forces into wk.lam1, sliders into wk.w_new and,
    if with_tangent, dLambda/dg1 blocks into wk.D. Returns the friction work of the step's slip [J]."""
    nt = p.nt
    d = 1 + nt
    npt = p.k_n.shape[0]
    e_fric = 0.0
    for i in range(npt):
        o = i * d
        ow = i * nt
        od = i * d * d
        _coulomb_disc(g1, o, nt, w_old, ow, p.k_n[i], p.k_t[i], p.mu[i], wk.lam1, o, wk.w_new, wk.D, od)
        ln, dln, _ = _normal_impulse(g0[o], g1[o], p.k_n[i])
        wk.lam[o] = ln
        for a in range(nt):
            dn, dt, ddn, _, ddt = _interface_dashpot(g0[o], g1[o], g0[o + 1 + a], g1[o + 1 + a],
                                                     p.cn_h[i], p.ct_h[i], p.depth)
            if a == 0:
                wk.lam[o] += dn
                dln += ddn
            wk.lam[o + 1 + a] = 0.5 * (wk.lam0[o + 1 + a] + wk.lam1[o + 1 + a]) + dt
            e_fric -= wk.lam1[o + 1 + a] * (wk.w_new[ow + a] - w_old[ow + a])   # f_t . dw >= 0
            if with_tangent:
                for b in range(d):
                    wk.D[od + (1 + a) * d + b] *= 0.5
                wk.D[od + (1 + a) * d + 1 + a] += ddt
        if with_tangent:
            wk.D[od] = dln
    return e_fric


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _factor_jacobian(p, wk):
    """LU of J = I - W blockdiag(D) into wk.LU (the blocks are the points' d x d tangents): column
    o + c of J is e_(o+c) - sum_k W[:, o + k] D_j[k, c] for point j's block at o = j d. The indices
    are unsigned (as plant.newmark._lu_factor: a signed index is wrapped at every access)."""
    m = numba.uint64(p.W.shape[0])
    d = numba.uint64(1 + p.nt)
    npt = m // d
    W = p.W
    Db = wk.D
    J = wk.LU
    for i in range(m):
        for jb in range(npt):
            o = jb * d
            od = o * d
            for c in range(d):
                acc = 0.0
                for kk in range(d):
                    acc += W[i, o + kk] * Db[od + kk * d + c]
                J[i, o + c] = -acc
        J[i, i] += 1.0
    _lu_factor(wk.LU, wk.piv, p.W.shape[0])
    wk.have_lu[0] = 1


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _residual(p, wk):
    """r = g1 - g_pred - W Lambda; returns (|r|_2, the round-off floor of |r|_2: ROUNDOFF times the
    largest sum of magnitudes |g1_i| + |g_pred_i| + sum_j |W_ij Lambda_j| that a residual entry cancels)."""
    m = p.W.shape[0]
    s = 0.0
    big = 0.0
    for i in range(m):
        acc = wk.g1[i] - wk.g_pred[i]
        mag = abs(wk.g1[i]) + abs(wk.g_pred[i])
        for j in range(m):
            t = p.W[i, j] * wk.lam[j]
            acc -= t
            mag += abs(t)
        wk.r[i] = acc
        s += acc * acc
        big = max(big, mag)
    return np.sqrt(s), ROUNDOFF * big * np.sqrt(m)


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _first_kink(p, wk, w):
    """The smallest alpha in (0, 1) at which a point of the gaps g_old - alpha dg changes branch of
    the end-point law (plant.contact3d._coulomb_disc): open <-> closed where g_n crosses 0, stick
    <-> slip where phi(alpha) = |f*|^2 - (mu f_n)^2 changes sign, with f* = k_t (g_t - w) and
    f_n = -k_n g_n linear in alpha (phi a quadratic); 2.0 if none. RT-safe."""
    nt = p.nt
    d = 1 + nt
    best = 2.0
    for i in range(p.k_n.shape[0]):
        o = i * d
        gn0 = wk.g_old[o]
        dgn = -wk.dg[o]
        closed_to = 1.0
        if dgn != 0.0 and (gn0 < 0.0) != (gn0 + dgn < 0.0):
            a = -gn0 / dgn
            if 0.0 < a < best:
                best = a
            closed_to = a
        if gn0 >= 0.0:
            continue
        kt2 = p.k_t[i] * p.k_t[i]
        mkn2 = p.mu[i] * p.mu[i] * p.k_n[i] * p.k_n[i]
        tt = 0.0
        tu = 0.0
        uu = 0.0
        for a in range(nt):
            t = wk.g_old[o + 1 + a] - w[i * nt + a]
            u = -wk.dg[o + 1 + a]
            tt += t * t
            tu += t * u
            uu += u * u
        qa = kt2 * uu - mkn2 * dgn * dgn
        qb = 2.0 * (kt2 * tu - mkn2 * gn0 * dgn)
        qc = kt2 * tt - mkn2 * gn0 * gn0
        lim = min(best, closed_to)
        if abs(qa) <= 1e-14 * (abs(qb) + abs(qc)):
            if qb != 0.0:
                r = -qc / qb
                if 0.0 < r < lim:
                    best = r
            continue
        disc = qb * qb - 4.0 * qa * qc
        if disc < 0.0:
            continue
        sq = math.sqrt(disc)
        qq = -0.5 * (qb + (sq if qb >= 0.0 else -sq))   # the roots without cancellation
        for r in (qq / qa, qc / qq if qq != 0.0 else 2.0):
            if 0.0 < r < lim:
                lim = r
                best = r
    return best


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _se_substep(q, qd, w, g, en, F_exc, F_N1, p, wk):
    """One Newmark substep of length p.h in place on (q, qd, w, g, en). Returns Newton iterations
    (-1 if not converged)."""
    n = q.shape[0]
    m = g.shape[0]
    nt = p.nt
    d = 1 + nt
    h = p.h
    # --- predictor and the start-point tangential forces
    for i in range(n):
        f = p.b_exc[i] * F_exc + p.b_N1[i] * F_N1 + p.f_const[i]
        if p.dyn[i] > 0.0:
            wk.q_pred[i] = q[i] + p.s2[i] * (f + 2.0 / h * qd[i] - p.omega2[i] * q[i])
        else:   # s2 = (1 + theta) / omega^2: q1 = (1 + theta) omega^-2 (f + (G^T Lambda)) - theta q0
            wk.q_pred[i] = p.s2[i] * f - p.qs_theta * q[i]
    for i in range(m):
        acc = p.gap0[i]
        for j in range(n):
            acc += p.G[i, j] * wk.q_pred[j]
        wk.g_pred[i] = acc
    for i in range(p.k_n.shape[0]):
        o = i * d
        wk.lam0[o] = 0.0
        for a in range(nt):
            wk.lam0[o + 1 + a] = -p.k_t[i] * (g[o + 1 + a] - w[i * nt + a]) if g[o] < 0.0 else 0.0
    # --- initial guess: the previous step's gaps. With the factors kept from that step (the tangent of
    # its contact pattern) the first Newton step is exact while no point changes branch (the step is
    # linear in g1 on a stick, open or closed branch); a fixed-point guess g_pred + W Lambda(g0, g0)
    # moved the sliding and just-closing points across the cone and took twice the iterations.
    for i in range(m):
        wk.g1[i] = g[i]
    # --- modified Newton with backtracking on |r|_2 (the residual is continuous and piecewise smooth:
    # a full step can cycle between stick and slip, a shortened one descends)
    it = 0
    refac = 0
    e_fric = _mean_forces(g, wk.g1, w, p, wk, True)
    rn, floor = _residual(p, wk)
    stale = wk.have_lu[0] == 0
    converged = False
    free_kink = True
    while it < p.max_iter:
        if rn <= p.tol + floor:
            converged = True
            break
        if stale:
            _factor_jacobian(p, wk)
            refac += 1
        for i in range(m):
            wk.dg[i] = wk.r[i]
            wk.g_old[i] = wk.g1[i]
        _lu_solve(wk.LU, wk.piv, wk.dg, m)
        alpha = 1.0
        rn_new = rn
        # the step to the first branch change: tried once, after a rejected full step
        kink = 2.0 if free_kink else -1.0
        for _ls in range(LINE_SEARCH):
            for i in range(m):
                wk.g1[i] = wk.g_old[i] - alpha * wk.dg[i]
            e_fric = _mean_forces(g, wk.g1, w, p, wk, True)
            rn_new, floor = _residual(p, wk)
            if rn_new <= (1.0 - 1e-4 * alpha) * rn or rn_new <= p.tol + floor or (alpha == kink and rn_new <= rn):
                break
            if kink > 1.0:
                kink = _first_kink(p, wk, w)
                if kink >= 1.0:
                    kink = -1.0   # no branch change before the full step
                else:
                    kink = kink * (1.0 + KINK_PAST) + KINK_PAST * 1e-3
                    alpha = kink
                    continue
            alpha = 0.5 if alpha == kink else 0.5 * alpha
        # a kink step is accepted without a decrease of |r|; after one that did not reduce it by
        # KINK_PROGRESS the next iteration backtracks only (a point on its branch boundary at the
        # round-off floor otherwise took the same kink step every iteration)
        free_kink = not (alpha == kink and rn_new > KINK_PROGRESS * rn and rn_new > p.tol + floor)
        stale = alpha < 1.0 or rn_new > REFACTOR_RATIO * rn
        rn = rn_new
        it += 1
    wk.counts[0] += it
    wk.counts[1] += refac
    if not converged:
        return -1
    # --- update: q1 = q_pred + s2 G^T Lambda, qd1 = 2 dq / h - qd0
    e_damp = 0.0
    w_exc = 0.0
    w_bolt = 0.0
    for j in range(n):
        acc = 0.0
        for i in range(m):
            acc += p.G[i, j] * wk.lam[i]
        wk.f_c[j] = acc
    for j in range(n):
        q1 = wk.q_pred[j] + p.s2[j] * wk.f_c[j]
        dq = q1 - q[j]
        qd1 = (2.0 * dq / h - qd[j]) * p.dyn[j]
        e_damp += p.c[j] * 0.25 * (qd[j] + qd1) * (qd[j] + qd1) * h
        w_exc += p.b_exc[j] * F_exc * dq
        w_bolt += p.b_N1[j] * F_N1 * dq
        q[j] = q1
        qd[j] = qd1
    for i in range(m):
        # dashpot work: -Lambda_d . dg; counted with the modal damping
        g[i] = wk.g1[i]
    for i in range(w.shape[0]):
        w[i] = wk.w_new[i]
    en[0] += e_fric
    en[1] += e_damp
    en[2] += w_exc
    en[3] += w_bolt
    return it


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _se_step(k, x, u, p, x_next, y, wk):
    """One controller step of the imported structure (p.substeps substeps). RT-safe.

    x = [q (n), qd (n), w (p nt), g (p d), E_fric, E_damp, W_exc, W_bolt]; u = (F_exc [N], F_N1 [N]).
    y = [sensor displacements (s), velocities (s), accelerations (s), u_rel [m], v_rel [m/s],
         F_b [N] adaptive bolt force, E_fric, E_damp, W_exc, W_bolt [J], Newton iterations,
         refactorisations, failed substeps, the sensors' mean accelerations over the step
         (v(t_k+1) - v(t_k)) / dt (s) [m/s^2] (what an anti-aliased accelerometer sees, as
         plant.newmark's abar), the adaptive bolt's separation force k_b (s - s_ref) [N]].
    Returns the Newton iterations (-1 if a substep failed).
    """
    n = p.omega2.shape[0]
    m = p.G.shape[0]
    nw = p.k_n.shape[0] * p.nt
    for i in range(x.shape[0]):
        x_next[i] = x[i]
    q = x_next[0:n]
    qd = x_next[n:2 * n]
    w = x_next[2 * n:2 * n + nw]
    g = x_next[2 * n + nw:2 * n + nw + m]
    en = x_next[2 * n + nw + m:2 * n + nw + m + N_ENERGY]
    wk.counts[0] = 0
    wk.counts[1] = 0
    its = 0
    failed = 0
    for _ in range(p.substeps):
        it = _se_substep(q, qd, w, g, en, u[0], u[1], p, wk)
        if it < 0:
            failed += 1
        else:
            its += it
    # --- outputs: end-point accelerations qdd = f + G^T lambda_end - c qd - omega^2 q
    for j in range(n):
        acc = p.b_exc[j] * u[0] + p.b_N1[j] * u[1] + p.f_const[j] - p.c[j] * qd[j] - p.omega2[j] * q[j]
        for i in range(m):
            acc += p.G[i, j] * wk.lam[i]
        wk.qdd[j] = acc * p.dyn[j]
    ns = p.S.shape[0] - 1
    for r in range(ns + 1):
        a0 = 0.0
        a1 = 0.0
        a2 = 0.0
        for j in range(n):
            a0 += p.S[r, j] * q[j]
            a1 += p.S[r, j] * qd[j]
            a2 += p.S[r, j] * wk.qdd[j]
        if r < ns:
            y[r] = a0
            y[ns + r] = a1
            y[2 * ns + r] = a2
        else:
            y[3 * ns] = a0
            y[3 * ns + 1] = a1
    sep = 0.0
    for j in range(n):
        sep += p.bolt_row[j] * q[j]
    o = 3 * ns + 2
    y[o] = u[1] + p.bolt_k * (sep - p.bolt_ref)
    for i in range(N_ENERGY):
        y[o + 1 + i] = en[i]
    y[o + 5] = wk.counts[0]
    y[o + 6] = wk.counts[1]
    y[o + 7] = failed
    inv_dt = 1.0 / (p.h * p.substeps)
    for r in range(ns):
        acc = 0.0
        for j in range(n):
            acc += p.S[r, j] * (qd[j] - x[n + j])
        y[o + 8 + r] = acc * inv_dt
    y[o + 8 + ns] = p.bolt_k * (sep - p.bolt_ref)
    return -1 if failed else its


# --- design time ---------------------------------------------------------------------------------

@dataclass(frozen=True)
class SEPlant:
    """A built superelement plant: kernel arrays and what interprets them."""
    se: Superelement
    params: SEParams
    Phi: np.ndarray
    omega: np.ndarray
    F_N1_initial: float

    @property
    def n(self) -> int:
        return len(self.omega)

    @property
    def n_points(self) -> int:
        return self.se.n_points

    @property
    def state_size(self) -> int:
        nt = self.params.nt
        return 2 * self.n + self.n_points * (nt + 1 + nt) + N_ENERGY

    def state_slots(self) -> dict[str, slice]:
        n, p, nt = self.n, self.n_points, self.params.nt
        o = 2 * n + p * nt
        return {"q": slice(0, n), "qd": slice(n, 2 * n), "w": slice(2 * n, o), "g": slice(o, o + p * (1 + nt)),
                "energy": slice(o + p * (1 + nt), o + p * (1 + nt) + N_ENERGY)}

    def output_labels(self) -> list[tuple[str, str]]:
        s = self.se.sensor_names
        return ([(f"w_{x}", "m") for x in s] + [(f"v_{x}", "m/s") for x in s] + [(f"a_{x}", "m/s^2") for x in s]
                + [("u_rel", "m"), ("v_rel", "m/s"), ("F_N1", "N"), ("E_fric", "J"), ("E_damp", "J"),
                   ("W_exc", "J"), ("W_screw", "J"), ("newton_iter", "-"), ("refactorisations", "-"),
                   ("substep_fallbacks", "-")] + [(f"abar_{x}", "m/s^2") for x in s] + [("dF_N1", "N")])

    def output_index(self) -> dict[str, int]:
        return {nm: i for i, (nm, _) in enumerate(self.output_labels())}

    def new_work(self) -> SEWork:
        n, m = self.n, self.params.G.shape[0]
        d = 1 + self.params.nt
        p = self.n_points
        return SEWork(q_pred=np.zeros(n), f_c=np.zeros(n), qdd=np.zeros(n), g_pred=np.zeros(m), g1=np.zeros(m),
                      lam=np.zeros(m), lam1=np.zeros(m), lam0=np.zeros(m), w_new=np.zeros(p * self.params.nt),
                      D=np.zeros(p * d * d), r=np.zeros(m), dg=np.zeros(m), g_old=np.zeros(m), LU=np.zeros((m, m)), piv=np.zeros(m, dtype=np.int64),
                      have_lu=np.zeros(1, dtype=np.int64), counts=np.zeros(2, dtype=np.int64))

    def initial_state(self, F_N1: float | None = None) -> np.ndarray:
        """Static equilibrium under the bolts (sliders from zero), at rest."""
        F = self.F_N1_initial if F_N1 is None else F_N1
        q, w, g = static_equilibrium(self.params, F)
        x = np.zeros(self.state_size)
        sl = self.state_slots()
        x[sl["q"]], x[sl["w"]], x[sl["g"]] = q, w, g
        return x


def contact_forces(p: SEParams, g: np.ndarray, w_old: np.ndarray):
    """End-point law over all points (design time): lambda (m,), w_new, dlambda/dg (m, m)."""
    m = len(g)
    nt = p.nt
    d = 1 + nt
    npt = m // d
    lam, w_new, Db = np.zeros(m), np.zeros(npt * nt), np.zeros(npt * d * d)
    for i in range(npt):
        _coulomb_disc(g, i * d, nt, w_old, i * nt, p.k_n[i], p.k_t[i], p.mu[i], lam, i * d, w_new, Db, i * d * d)
    D = sla.block_diag(*Db.reshape(npt, d, d))
    return lam, w_new, D


def static_equilibrium(p: SEParams, F_N1: float, K: np.ndarray | None = None, max_iter: int = 100):
    """K q = f_const + b_N1 F_N1 + G^T lambda(G q + gap0, w = 0); Newton from the all-closed, all-stuck
    solution. Returns (q, w, g). RuntimeError (one line, with the reason of ``no_equilibrium_reason``)
    if it does not converge or a Newton matrix is singular."""
    try:
        return _static_equilibrium(p, F_N1, K, max_iter)
    except (RuntimeError, np.linalg.LinAlgError):
        pass
    raise RuntimeError(f"no static equilibrium under the bolts at F_N1 = {F_N1:g} N: "
                       f"{no_equilibrium_reason(p, F_N1, K, max_iter)}") from None


UNLIMITED_MU = 1e6   # a friction coefficient that no tangential load of a bolted joint reaches


def no_equilibrium_reason(p: SEParams, F_N1: float, K: np.ndarray | None = None, max_iter: int = 100) -> str:
    """Why ``static_equilibrium`` finds no solution, from two cheaper problems of the same form:

    * if the stiffness with every point closed and stuck (bilateral) is singular (an eigenvalue
      below 1e-9 of the largest): a mechanism, the contact points and their friction directions
      leave a rigid-body motion free (e.g. one point with 1-D friction), and the Newton matrix is
      singular whatever the load (whether its solve then converges depends on round-off);
    * else, with unlimited friction (mu = ``UNLIMITED_MU``) it converges: the friction limit is what
      fails, the closed points cannot hold the tangential load of the bolts' preload; the smallest
      mu that holds is bisected (geometric, to 5 %) and named, rounded up to 3 digits;
    * else the points the preload closes cannot balance its moment by compression alone (the
      structure tips off the interface).

    Each ends with the fix a user has (another coarsening, more points)."""
    import scipy.linalg as sla_
    K_ = np.diag(p.omega2) if K is None else K
    fix = "a coarsened interface: another --clusters (more points, or clusters that follow the bolts' footprints)"

    def holds(mu: float) -> bool:   # a probe: at most 40 Newton iterations
        try:
            _static_equilibrium(p._replace(mu=np.full_like(p.mu, mu)), F_N1, K_, min(max_iter, 40))
            return True
        except (RuntimeError, np.linalg.LinAlgError):
            return False

    d = 1 + p.nt
    kc = np.zeros(p.G.shape[0])
    kc[0::d] = p.k_n
    for a in range(1, d):
        kc[a::d] = p.k_t
    A = K_ + (p.G.T * kc) @ p.G
    lam = sla_.eigvalsh(0.5 * (A + A.T))
    n_free = int(np.sum(lam <= 1e-9 * lam[-1]))
    if n_free:
        return (f"even with all {len(p.k_n)} contact point(s) closed and stuck ({p.nt}-D friction), {n_free} "
                f"rigid-body motion(s) of the structure stay free (a mechanism); {fix}")
    mu0 = float(np.max(p.mu))
    if holds(UNLIMITED_MU):
        lo, hi = mu0, UNLIMITED_MU
        while hi / lo > 1.05:
            mid = float(np.sqrt(lo * hi))
            lo, hi = (lo, mid) if holds(mid) else (mid, hi)
        step = 10.0 ** (np.floor(np.log10(hi)) - 2)   # hi rounded up to 3 digits: a value that holds
        return (f"the closed points' friction cannot hold the structure under the bolts' preload (it holds from "
                f"mu = {np.ceil(hi / step) * step:.3g}, the interface's is {mu0:g}); {fix}")
    return (f"the points the preload closes cannot balance it by compression (the structure tips off the "
            f"interface, also with unlimited friction); {fix}")


def _static_equilibrium(p: SEParams, F_N1: float, K: np.ndarray | None, max_iter: int):
    K = np.diag(p.omega2) if K is None else K
    f = p.f_const + p.b_N1 * F_N1
    m = p.G.shape[0]
    d = 1 + p.nt
    kc = np.zeros(m)
    kc[0::d] = p.k_n
    for a in range(1, d):
        kc[a::d] = p.k_t
    q = np.linalg.solve(K + (p.G.T * kc) @ p.G, f - p.G.T @ (kc * p.gap0))
    w0 = np.zeros(m // d * p.nt)

    def resid(q):
        g = p.G @ q + p.gap0
        lam, w, D = contact_forces(p, g, w0)
        return K @ q - f - p.G.T @ lam, w, g, D

    R, w, g, D = resid(q)
    for _ in range(max_iter):
        if np.max(np.abs(R)) <= 1e-10 * max(1.0, np.max(np.abs(f))):
            return q, w, g
        dq = np.linalg.solve(K - p.G.T @ D @ p.G, R)
        r0 = np.linalg.norm(R)
        alpha = 1.0
        for _ls in range(30):    # backtracking: a full step can cycle between stick and slip
            Rn, wn, gn, Dn = resid(q - alpha * dq)
            if np.linalg.norm(Rn) <= (1.0 - 1e-4 * alpha) * r0:
                break
            alpha *= 0.5
        q = q - alpha * dq
        R, w, g, D = Rn, wn, gn, Dn
    raise RuntimeError(f"static equilibrium under the bolts did not converge in {max_iter} Newton iterations "
                       f"(F_N1 = {F_N1:g} N)")


def build_se_plant(se: Superelement, cfg, F_N1: float | None = None) -> SEPlant:
    """The plant of an imported structure with the configuration's interface (per unit area: k_n_area,
    k_t_area, mu, tau_s, dashpot_depth_m), modal damping (used if the superelement has no C), step
    (dt_s / plant.substeps) and Newton tolerance. F_N1 [N]: the adaptive bolt's preload at which its
    reference separation is set (default: the configured adaptive screw's F_N, else 0)."""
    itf = cfg.plant.interface
    n = se.n
    K = se.K.copy()
    r_b = np.zeros(n) if se.adaptive_row is None else se.adaptive_row
    k_b = float(se.adaptive_k) if se.adaptive_row is not None else 0.0
    K += k_b * np.outer(r_b, r_b)
    lam, Phi = sla.eigh(0.5 * (K + K.T), 0.5 * (se.M + se.M.T))
    omega = np.sqrt(np.maximum(lam, 0.0))
    omega = np.where(omega < RIGID_BODY_RAD_S, 0.0, omega)
    if se.C is not None:
        c = np.einsum("ij,ik,kj->j", Phi, se.C, Phi)
    else:
        c = 2.0 * cfg.plant.modal_damping * omega
    h = cfg.dt_s / cfg.plant.substeps
    nt = se.friction_dims
    d = 1 + nt
    p = se.n_points
    G = np.ascontiguousarray(se.contact_rows.reshape(p * d, n) @ Phi)
    gap0 = np.zeros(p * d)
    if se.contact_gap0 is not None:
        gap0[0::d] = se.contact_gap0
    S_rows = np.vstack([se.sensor_rows.reshape(-1, n), (np.zeros(n) if se.u_rel_row is None else se.u_rel_row)[None]])
    b_exc = Phi.T @ se.excitation[0] if se.excitation.size else np.zeros(n)
    f_bolts = np.zeros(n) if se.f_bolts is None else se.f_bolts
    k_n = itf.k_n_area * se.contact_area
    k_t = itf.k_t_area * se.contact_area
    from frictionrt.rt.common.config import adaptive_screw
    screw = adaptive_screw(cfg)
    F0 = (screw.F_N if screw is not None else 0.0) if F_N1 is None else float(F_N1)
    b_N1 = -(Phi.T @ r_b)
    f_const = Phi.T @ f_bolts
    S_modal = S_rows @ Phi
    theta = float(cfg.plant.quasi_static_theta)
    dyn = (omega <= 2 * np.pi * cfg.plant.quasi_static_hz).astype(float)
    qs = dyn == 0
    if qs.any() and cfg.plant.condense_quasi_static:
        # the quasi-static modes replaced by their Ritz modes on the subspace the step reaches,
        # range(Omega_s^-1 [b_exc, b_N1, f_const, G_s^T]) (as plant.model.condense_quasi_static)
        loads = np.column_stack([b_exc, b_N1, f_const, G.T])[qs]
        om = omega[qs]
        U, sv, _ = np.linalg.svd(loads / om[:, None], full_matrices=False)
        U = U[:, sv > 1e-12 * sv[0]]
        sr, Y = np.linalg.eigh(U.T @ (U / om[:, None] ** 2))
        sr, Y = sr[::-1], Y[:, ::-1]
        Vr = (U / om[:, None]) @ Y / np.sqrt(sr)
        nd = int((~qs).sum())
        T = np.zeros((len(qs), nd + Vr.shape[1]))
        T[np.flatnonzero(~qs), np.arange(nd)] = 1.0
        T[np.flatnonzero(qs), nd:] = Vr
        omega = np.concatenate([omega[~qs], 1.0 / np.sqrt(sr)])
        c = np.concatenate([c[~qs], np.zeros(len(sr))])
        dyn = np.concatenate([np.ones(nd), np.zeros(len(sr))])
        G, b_exc, b_N1, f_const, S_modal = (np.ascontiguousarray(G @ T), T.T @ b_exc, T.T @ b_N1, T.T @ f_const,
                                            np.ascontiguousarray(S_modal @ T))
        Phi = Phi @ T
    c = c * dyn
    s2 = np.where(dyn > 0, 2.0 / (omega**2 + 2.0 / h * c + 4.0 / h**2), (1.0 + theta) / np.maximum(omega, 1.0) ** 2)
    params = SEParams(
        omega2=omega**2, dyn=dyn, qs_theta=theta, c=c, s2=s2, G=G, gap0=gap0, W=np.ascontiguousarray((G * s2) @ G.T),
        b_exc=b_exc, b_N1=b_N1, f_const=f_const, S=S_modal, bolt_row=-b_N1, bolt_k=k_b, bolt_ref=0.0, k_n=k_n, k_t=k_t, mu=np.full(p, itf.mu),
        cn_h=k_n * itf.tau_s / h, ct_h=k_t * itf.tau_s / h, depth=float(itf.dashpot_depth_m), nt=int(nt),
        h=float(h), substeps=int(cfg.plant.substeps), tol=float(cfg.plant.newton_tol_m),
        max_iter=int(cfg.plant.newton_max_iter))
    if k_b > 0.0:
        # the bolt is tightened to F0 in the assembled static state: s_ref is the separation there
        K_free = np.diag(params.omega2) - k_b * np.outer(params.bolt_row, params.bolt_row)
        q, _, _ = static_equilibrium(params, F0, K=K_free)
        s_ref = float(params.bolt_row @ q)
        params = params._replace(bolt_ref=s_ref, f_const=params.f_const + params.bolt_row * k_b * s_ref)
    for a in params:
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    return SEPlant(se, params, Phi, omega, F0)


def stuck_frequencies_hz(plant: SEPlant, F_N1: float | None = None, closed_only: bool = True) -> np.ndarray:
    """Eigenfrequencies [Hz] with the contact linearised as stuck (k_n, k_t) at the points the
    bolts close (static equilibrium at F_N1), or at all points (closed_only False). Rigid-body
    modes (< 1 mHz) excluded."""
    p = plant.params
    d = 1 + p.nt
    mask = np.ones(plant.n_points, bool)
    if closed_only:
        x0 = plant.initial_state(F_N1)
        mask = x0[plant.state_slots()["g"]][0::d] < 0.0
    kc = np.zeros(p.G.shape[0])
    kc[0::d] = p.k_n * mask
    for a in range(1, d):
        kc[a::d] = p.k_t * mask
    lam = sla.eigvalsh(np.diag(p.omega2) + (p.G.T * kc) @ p.G)
    f = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
    return f[f > 1e-3]


@numba.njit(cache=True, nogil=True)
def _run(x0, U, p, wk, Y):
    x = x0.copy()
    x_next = np.empty_like(x0)
    failed = 0
    for k in range(U.shape[0]):
        if _se_step(k, x, U[k], p, x_next, Y[k], wk) < 0:
            failed += 1
        x, x_next = x_next, x
    return x, failed


def run(plant: SEPlant, F_exc: np.ndarray, F_N1: np.ndarray | float, x0: np.ndarray | None = None):
    """Simulate len(F_exc) controller steps; returns (Y, x_final). RuntimeError on a failed solve or NaN."""
    F_exc = np.asarray(F_exc, dtype=np.float64)
    U = np.empty((len(F_exc), 2))
    U[:, 0] = F_exc
    U[:, 1] = F_N1
    if x0 is None:
        x0 = plant.initial_state(float(U[0, 1]))
    Y = np.zeros((len(F_exc), len(plant.output_labels())))
    x, failed = _run(x0, U, plant.params, plant.new_work(), Y)
    if failed:
        raise RuntimeError(f"the contact solve did not converge in {failed} of {len(U)} steps; raise "
                           "plant.substeps or plant.newton_max_iter")
    if not np.all(np.isfinite(Y)):
        raise RuntimeError("the plant produced NaN/Inf: check the superelement's units and the interface stiffnesses")
    return Y, x
