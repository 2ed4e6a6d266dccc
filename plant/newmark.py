"""The plant step: Newmark average acceleration on the modes of the bolted assembly with Newton
iterations on the contact gaps (SPEC section 2, "Time integration"). RT-safe, allocation-free.

Condensation. The beams' (Craig-Bampton reduced or full) linear part with the bolts' springs is
diagonalised once at design time: M = I, D = diag(c), K = diag(omega^2) in modal coordinates q,
with c = 2 zeta omega; modes with dyn = 0 are quasi-static (no inertia: q1 = (1 + theta) q_s -
theta q0 with q_s their static response to the step's mean load, s2 = (1 + theta)/omega^2, qd = 0;
docs/plant.md 2.6). Average-acceleration Newmark (beta = 1/4, gamma = 1/2) is the trapezoidal
rule; in its mean form over a step of length h, with dq = q1 - q0,

    (qd1 - qd0)/h + c (qd0 + qd1)/2 + omega^2 (q0 + q1)/2 = f_mean + (G^T Lambda)_i,
    qd1 + qd0 = 2 dq / h,

so per mode  q1 = q0 + s2 (f_mean + (2/h) qd0 - omega^2 q0)  +  s2 (G^T Lambda)
                 = q_pred                                      +  s2 G^T Lambda,
         s2 = 2 / (omega^2 + (2/h) c + 4/h^2).

Period matching (plant.period_match, docs/plant.md 2.2): the trapezoidal rule maps a mode of
frequency omega to the discrete frequency (2/h) atan(omega h / 2), periods elongated by
(omega h)^2 / 12 (0.27 % at 620 Hz, 0.8 % at 1050 Hz at 21 kHz). A stepped mode gets the modal
mass m = (omega / omega_d)^2 with omega_d = (2/h) tan(omega h / 2), and the damping
c = 2 zeta omega^2 / omega_d x omega h / sin(omega h): the step's free mode then oscillates at
omega with damping ratio zeta (to first order in zeta), and its static response omega^-2 is
unchanged. The mean form becomes m (qd1 - qd0)/h + ..., so the predictor carries (2/h) m qd0,
s2 = 2 / (omega^2 + (2/h) c + 4 m/h^2), T = 1/2 sum m qd^2. The model (its modes, FRFs) is not
changed; the step converges to it as h -> 0 (m -> 1).

and the contact gaps g1 = G q1 obey the small system of the contact pairs only

    g1 = g_pred + W Lambda(g0, g1, w0),        W = G diag(s2) G^T   (2p x 2p, constant),

solved by Newton (Jacobian I - W dLambda/dg1, LU cached per contact pattern).

Lambda is the mean contact force over the step: for the normal spring its discrete gradient
(``frictionrt.plant.contact._normal_impulse``), for the Jenkins element (or each element of an Iwan
element) the mean of its end-point forces (the trapezoid). Both are what average acceleration
gives while no pair changes state; across an impact the discrete gradient keeps the contact's
work equal to its energy change, so the energy balance holds to round-off (no energy pumped by
chatter).

Inputs are held over the step (zero-order hold), so f_mean is the held value and the input
work over a step is F * (b . dq).

State vector x (see ``frictionrt.plant.model.PlantModel.state_slots``): q, qd (n each), sliders w (p N:
N = 1 Jenkins element per pair, or the N elements of an Iwan element, pair-major),
gaps g (2p), then E_fric, E_damp, W_exc, W_screw [J].

Length: the plant's step kernel and the contact solve it inlines (Newton, the fallback split,
the substeps) are one unit of numerics compiled together; splitting them would only move the
inlined helpers away from the one function that uses them.
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from frictionrt.plant.contact import (
    _interface_dashpot,
    _interface_dashpot_at,
    _iwan_pair,
    _jenkins_pair,
    _normal_impulse,
    _stribeck_mu,
)

# reassociation (SIMD dot products) and FMA contraction only: NaN/Inf semantics are kept
FASTMATH = {"reassoc", "contract"}
# The kernels never allocate, so they are compiled without numba's reference counting
# (_nrt=False; numba refuses at compile time if a function needed it). With it, every array
# taken from the NamedTuples would be incref'd/decref'd atomically per call (about half the
# step's time at 9 pairs). The flag is numba's own (used in its test suite) but not in its
# public docs: pyproject pins numba's range and tests/test_realtime_properties.py checks it.
PLAIN_ITER = 4  # Newton iterations before steps are shortened by backtracking
ROUNDOFF = 64 * np.finfo(np.float64).eps  # relative floor of the Newton tolerance on the gaps
SLIP_TIE = 1e-13  # relative band at the friction limit in which a slipping pair stays slipping
N_ENERGY = 4    # E_fric, E_damp, W_exc, W_screw
TRANSITION = -2  # contact code of a pair that opens or closes within the step
MAX_UPDATES = 4  # rank-one updates of the kept factors before they are refreshed (``_fading_updates``)
FACTOR_SLOTS = 32  # contact patterns whose factors are kept (``_use_cached``; docs/plant.md 2.3), plus
                   # one slot for a pattern with a pair in transition (used once: not inverted, not kept)


class PlantParams(NamedTuple):
    """Constant arrays of the plant step (built by ``frictionrt.plant.model.build_plant``)."""
    omega2: np.ndarray     # (n,) omega^2 [1/s^2]
    dyn: np.ndarray        # (n,) 1.0 for a mode stepped by Newmark, 0.0 for a quasi-static one (no inertia)
    c: np.ndarray          # (n,) 2 zeta omega [1/s] (the model's damping)
    c_step: np.ndarray     # (n,) damping of the stepped modes [1/s] (c, or period-matched: docs/plant.md 2.2)
    m_step: np.ndarray     # (n,) modal mass of the stepped modes [-] (1, or period-matched)
    s2: np.ndarray         # (n,) 2 / (omega^2 + 2 c_step/h + 4 m_step/h^2) [s^2]
    G: np.ndarray          # (2p, n) modal -> gaps (g_n, g_t interleaved) [m]
    W: np.ndarray          # (2p, 2p) Delassus matrix G diag(s2) G^T [m/N]
    b_exc: np.ndarray      # (n,) modal load of a unit excitation force
    b_N1: np.ndarray       # (n,) modal load of a unit adaptive screw force
    f_const: np.ndarray    # (n,) modal load of the constant screws [N]
    out_rows: np.ndarray   # (n_pts + 1, n) w at points, then u_rel
    out_G: np.ndarray      # (n_pts + 1, 2p) out_rows G^T: contact force -> output acceleration
    k_n: np.ndarray        # (p,) [N/m]
    k_t: np.ndarray        # (p,) [N/m]
    mu: np.ndarray         # (p,) [-]
    c_n: np.ndarray        # (p,) normal interface dashpot k_n tau [N s/m]
    c_t: np.ndarray        # (p,) tangential interface dashpot k_t tau [N s/m]
    dashpot_depth: float   # penetration over which the tangential dashpot fades in [m]
    h: float               # substep [s]
    substeps: int
    s2_fine: np.ndarray    # (n,) s2 for the fallback substep h_fine
    W_fine: np.ndarray     # (2p, 2p) W for the fallback substep h_fine
    h_fine: float          # h / fine_split [s]
    qs_theta: float        # theta of the quasi-static modes: q1 = (1 + theta) q_static - theta q0 [-]
    n_dyn: int             # the stepped modes are the first n_dyn (dyn = 1), the quasi-static ones follow
    gq_exc: np.ndarray     # (2p,) the quasi-static modes' share of g_pred per unit F_exc, G_s diag(s2_s) b_exc_s [m/N]
    gq_N1: np.ndarray      # (2p,) the same per unit F_N1 [m/N]
    gq_const: np.ndarray   # (2p,) the same of the constant screws' load [m]
    fine_split: int        # fallback substeps per failed substep
    tol: float             # Newton tolerance on |r|_2 [m]
    max_iter: int
    static_excess: float   # Stribeck s: mu_s = (1 + s) mu [-]; 0 = Coulomb (mu constant)
    stribeck_v: float      # Stribeck velocity v_s [m/s]
    iwan_k: np.ndarray     # (N,) element stiffness fractions k_i / k_t (N = 1: [1], the Jenkins element)
    iwan_q: np.ndarray     # (N,) element slip-limit fractions q_i / (mu f_n)
    bolt_rows: np.ndarray  # (n_b, n) modal -> the beams' separation at each screw [m] (docs/plant.md 1.4)
    bolt_k: np.ndarray     # (n_b,) bolt axial stiffness [N/m] (in omega2: the modes are the bolted assembly's)
    bolt_F: np.ndarray     # (n_b,) preload of each ordinary bolt [N] (the adaptive screw's: the input F_N1)
    bolt_ref: np.ndarray   # (n_b,) separation at which a bolt carries its preload [m]
    bolt_adaptive: int     # index of the adaptive screw among the bolts
    scheme: int = 0        # the step: 0 trapezoidal, 1 generalized-alpha (``_substep``; plant.step_scheme)
    ga_am: float = 0.5     # generalized-alpha alpha_m, alpha_f, beta, gamma (Chung & Hulbert 1993) [-]
    ga_af: float = 0.5
    ga_beta: float = 0.25
    ga_gamma: float = 0.5
    law_w0: float = 0.5    # weight of the start point's force in the contact law's Lambda (0.5: the trapezoid's
                           # mean, 0: generalized-alpha's end-point force)


class PlantWork(NamedTuple):
    """Scratch buffers of the plant step (preallocated once by ``PlantModel.new_work``)."""
    q_pred: np.ndarray     # (n,)
    q_g: np.ndarray        # (n,) q_pred + theta q of the stepped modes (first p.n_dyn): their part of g_pred
    qdd_lin: np.ndarray    # (n,) modal acceleration at the end point without the contact forces
    f_c: np.ndarray        # (n,) modal contact force G^T Lambda
    g_pred: np.ndarray     # (2p,)
    g0: np.ndarray         # (2p,) gaps at the start of the step
    lam: np.ndarray        # (2p,) mean contact force Lambda over the step
    lam1: np.ndarray       # (2p,) end-point force lambda(g1) of the springs and sliders
    lamd: np.ndarray       # (2p,) interface dashpot force over the step (included in lam)
    w_new: np.ndarray      # (p N,) slider positions at the end of the step
    d: np.ndarray          # (3p,) dLambda_n/dg_n1, dLambda_t/dg_n1, dLambda_t/dg_t1
    code: np.ndarray       # (p,) int64 contact state per pair of the current iterate
    r: np.ndarray          # (2p,)
    dg: np.ndarray         # (2p,) Newton step
    g_old: np.ndarray      # (2p,) iterate before the step
    LU: np.ndarray         # (2p, 2p) LU factors of the active block of the Jacobian being factorised
    Jinv: np.ndarray       # (K + 1, 2p, 2p) per slot: L^-1 and U^-1 of its `pattern`'s factors (_triangular_inverses;
                           # not of the last slot, the transitions', which solves with LU)
    piv: np.ndarray        # (K + 1, 2p) int64 per slot: row pivots of its factors
    act: np.ndarray        # (p,) int64 active pairs of the current iterate (first n_act entries)
    ra: np.ndarray         # (2p,) right-hand side / solution of the active block
    ry: np.ndarray         # (2p,) scratch of _inverse_solve
    z: np.ndarray          # (2p,) J^-1 W e_n of a pair opening or closing within the step (_transition_step)
    pattern: np.ndarray    # (K + 1, p) int64 per slot: contact state per pair its LU belongs to (-1: none)
    mu_eff: np.ndarray     # (p,) friction coefficient of the current substep (p.mu without Stribeck)
    d_fact: np.ndarray     # (K + 1, 3p) per slot: the Jacobian entries wk.d its LU was factorised with
    upd: np.ndarray        # (1 + 2 MAX_UPDATES,) int64: rank-one updates of the factors (0..MAX_UPDATES), their
                           # columns in the active block, their pairs
    upd_delta: np.ndarray  # (MAX_UPDATES,) their changes of dLambda_t/dg_t [N/m]
    cap: np.ndarray        # (MAX_UPDATES, MAX_UPDATES + 1) the updates' capacitance system (``_apply_updates``)
    Z: np.ndarray          # (K + 1, p, 2p) per slot: J_aa^-1 u of a pair's update, kept with the factors
                           # (_fading_updates)
    z_ok: np.ndarray       # (K + 1, p) int64 per slot: 1 where Z holds the pair's row for its factors
    slot: np.ndarray       # (2,) int64: the slot whose factors the step uses, and a use counter
    last_use: np.ndarray   # (K + 1,) int64 the counter at each slot's last use (least recently used is refactorised)
    key: np.ndarray        # (K + 1,) int64 per slot: a hash of its pattern, compared before the pattern itself
    gs: np.ndarray         # (p,) normal gap at which the tangential dashpots' fade-in weight is taken [m]


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _lu_factor(A, piv, n):
    """LU factorisation with partial pivoting of the leading n x n block of A, in place
    (L unit lower, U upper). RT-safe.

    The indices are unsigned (numba.uint64): a signed index that LLVM cannot prove non-negative
    (range(k + 1, n)) is wrapped by numba at every access, which kept the inner update from
    being vectorised (16 x 16, the graded default's usual block: 0.91 -> 0.62 us, same factors
    bit for bit). Every operand is unsigned: numba types uint64 op int64 as float64."""
    nn = numba.uint64(n)
    one = numba.uint64(1)
    for k in range(nn):
        p = k
        amax = abs(A[k, k])
        for i in range(k + one, nn):
            if abs(A[i, k]) > amax:
                amax = abs(A[i, k])
                p = i
        piv[k] = p
        if p != k:
            for j in range(nn):
                tmp = A[k, j]
                A[k, j] = A[p, j]
                A[p, j] = tmp
        inv = 1.0 / A[k, k]
        for i in range(k + one, nn):
            A[i, k] *= inv
            f = A[i, k]
            if f != 0.0:
                for j in range(k + one, nn):
                    A[i, j] -= f * A[k, j]


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _lu_solve(LU, piv, b, n):
    """Solve with the factors of ``_lu_factor`` (leading n x n block); b[:n] is overwritten by
    the solution (substitution: for factors used once, where inverting them would cost more than
    it saves). RT-safe."""
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


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _triangular_inverses(LU, X, n):
    """The inverses of the factors of ``_lu_factor`` (leading n x n block of LU) into X: its strict
    lower part L^-1 (unit diagonal implied), its upper part with the diagonal U^-1. RT-safe.

    A solve with them (``_inverse_solve``) is two triangular matrix-vector products whose rows are
    independent, where substitution is a chain of n dependent dot products: 0.08 against 0.29 us
    at 16 x 16. They cost about twice the factorisation, paid once per factorisation while the
    factors serve many solves (docs/plant.md 2.3). Unsigned indices as in ``_lu_factor``."""
    nn = numba.uint64(n)
    one = numba.uint64(1)
    for j in range(nn):  # L^-1 by columns: X_ij = -L_ij - sum_{j<k<i} L_ik X_kj
        for i in range(j + one, nn):
            acc = -LU[i, j]
            for k in range(j + one, i):
                acc -= LU[i, k] * X[k, j]
            X[i, j] = acc
    for ii in range(nn):  # U^-1 by rows from the last: X_ij = -(sum_{i<k<=j} U_ik X_kj) / U_ii
        i = nn - one - ii
        inv = 1.0 / LU[i, i]
        X[i, i] = inv
        for j in range(i + one, nn):
            acc = 0.0
            for k in range(i + one, j + one):
                acc += LU[i, k] * X[k, j]
            X[i, j] = -acc * inv


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _inverse_solve(X, piv, b, y, n):
    """b[:n] = A^-1 b[:n] with the row pivots of ``_lu_factor`` and the inverted factors of
    ``_triangular_inverses`` (P A = L U: b <- U^-1 L^-1 P b); y (>= n,) is scratch. RT-safe."""
    nn = numba.uint64(n)
    for k in range(nn):
        p = numba.uint64(piv[k])
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
    for i in range(nn):
        acc = b[i]
        for j in range(i):
            acc += X[i, j] * b[j]
        y[i] = acc
    for i in range(nn):
        acc = 0.0
        for j in range(i, nn):
            acc += X[i, j] * y[j]
        b[i] = acc


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _normal_alpha(g0, g1, k_n, af):
    """A pair's normal spring force weighted between the step's ends, Lambda_n = af f_n(g0) +
    (1 - af) f_n(g1) with f_n = k_n max(0, -g) [N] (the generalized-alpha step: af = 0, the
    end-point force), its derivative in g1 [N/m], and True if the
    pair opens or closes within the step. Piecewise affine in g1 (no hyperbola: Newton is exact
    within a piece). RT-safe."""
    f0 = -k_n * g0 if g0 < 0.0 else 0.0
    if g1 < 0.0:
        return af * f0 - (1.0 - af) * k_n * g1, -(1.0 - af) * k_n, not (g0 < 0.0)
    return af * f0, 0.0, g0 < 0.0


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _contact_laws(g, w_old, p, wk, inv_h):
    """Evaluate the mean contact force Lambda(g0 = wk.g0, g1 = g) of every pair.

    Fills wk.lam, wk.lam1, wk.w_new, wk.d (Jacobian entries), wk.code and the active pairs
    wk.act[:n_act] (closed at the end of the step, or opening/closing within it; all others
    have Lambda = 0). The tangential law is the Jenkins element (p.iwan_k of length 1) or the
    Iwan element (``frictionrt.plant.contact._iwan_pair``; code 1 + sum_i s_i 3^i over its elements), with
    the friction coefficient wk.mu_eff of the substep. Returns (n_act, True if every pair's state
    equals wk.pattern and none opens or closes). A pair whose tangential dashpot is fading in
    (0 < s < 1) keeps its code: its law is affine within the step, s being lagged, but its Jacobian
    entry changes from step to step (``_fading_updates``). RT-safe.
    """
    # fields unpacked into locals: inside loops numba would reload every array pointer from
    # the NamedTuples (measured 0.29 -> 0.08 us for these 9 pair laws); likewise below
    lam, lam1, lamd, w_new, d = wk.lam, wk.lam1, wk.lamd, wk.w_new, wk.d
    code, act, pattern = wk.code, wk.act, wk.pattern[wk.slot[0]]
    g0, k_n, k_t, mu, c_n, c_t, depth = wk.g0, p.k_n, p.k_t, wk.mu_eff, p.c_n, p.c_t, p.dashpot_depth
    kf, qf = p.iwan_k, p.iwan_q
    ne = kf.shape[0]
    ga = p.scheme == 1
    af = p.law_w0
    wt = 1.0 - af   # weight of the end point's force in Lambda (0.5: the trapezoid)
    gs = wk.gs
    n_act = 0
    same = True
    for j in range(g.shape[0] // 2):
        if g0[2 * j] >= 0.0 and g[2 * j] >= 0.0:  # open at both ends: no force, slider relaxed
            lam[2 * j] = 0.0
            lam[2 * j + 1] = 0.0
            lam1[2 * j] = 0.0
            lam1[2 * j + 1] = 0.0
            for i in range(ne):
                w_new[j * ne + i] = g[2 * j + 1]
            lamd[2 * j] = 0.0
            lamd[2 * j + 1] = 0.0
            d[3 * j] = 0.0
            d[3 * j + 1] = 0.0
            d[3 * j + 2] = 0.0
            code[j] = 0
            same = same and pattern[j] == 0
            continue
        if ga:
            ln, dln, moved = _normal_alpha(g0[2 * j], g[2 * j], k_n[j], af)
        else:
            ln, dln, moved = _normal_impulse(g0[2 * j], g[2 * j], k_n[j])
        if ne > 1:  # Iwan element
            lt0 = 0.0
            for i in range(ne):
                lt0 -= k_t[j] * kf[i] * (g0[2 * j + 1] - w_old[j * ne + i])
            fn1, lt1, dtn, dtt, c = _iwan_pair(g[2 * j], g[2 * j + 1], w_old, w_new, j * ne, k_n[j], k_t[j],
                                               mu[j], kf, qf, pattern[j], SLIP_TIE)
            lam[2 * j] = ln
            lam[2 * j + 1] = af * lt0 + wt * lt1 if ga else 0.5 * (lt0 + lt1)
            lam1[2 * j] = fn1
            lam1[2 * j + 1] = lt1
            d[3 * j] = dln
            d[3 * j + 1] = wt * dtn
            d[3 * j + 2] = wt * dtt
            if moved:
                c = TRANSITION
        else:  # Jenkins element
            fn1, lt1, wn, _, dtn, dtt = _jenkins_pair(g[2 * j], g[2 * j + 1], w_old[j], k_n[j], k_t[j], mu[j])
            lt0 = -k_t[j] * (g0[2 * j + 1] - w_old[j])
            lam[2 * j] = ln
            lam[2 * j + 1] = af * lt0 + wt * lt1 if ga else 0.5 * (lt0 + lt1)
            lam1[2 * j] = fn1
            lam1[2 * j + 1] = lt1
            w_new[j] = wn
            d[3 * j] = dln
            d[3 * j + 1] = wt * dtn
            d[3 * j + 2] = wt * dtt
            if moved:
                c = TRANSITION
            elif fn1 == 0.0:
                c = 0
            else:
                c = 1 if dtn == 0.0 else (2 if dtn > 0.0 else 3)
                if c == 1 and (pattern[j] == 2 or pattern[j] == 3):
                    # a pair that slipped sits on its friction limit at the start of the next step,
                    # where stick and slip give the same force; keep it slipping in the same
                    # direction (else Newton takes a stick step first and needs a second one)
                    f_star = k_t[j] * (g[2 * j + 1] - w_old[j])
                    sgn = 1.0 if pattern[j] == 2 else -1.0
                    limit = mu[j] * fn1
                    if f_star * sgn >= limit * (1.0 - SLIP_TIE):
                        lt1 = -limit * sgn
                        wn = g[2 * j + 1] - limit * sgn / k_t[j]
                        dtn = mu[j] * k_n[j] * sgn
                        dtt = 0.0
                        c = pattern[j]
                        lam[2 * j + 1] = af * lt0 + wt * lt1 if ga else 0.5 * (lt0 + lt1)
                        lam1[2 * j + 1] = lt1
                        w_new[j] = wn
                        d[3 * j + 1] = wt * dtn
                        d[3 * j + 2] = 0.0
        ldn, ldt, ddn, ddtn, ddtt = _interface_dashpot_at(g0[2 * j], g[2 * j], g0[2 * j + 1], g[2 * j + 1],
                                                          c_n[j] * inv_h, c_t[j] * inv_h, depth, gs[j])
        lam[2 * j] += ldn
        lam[2 * j + 1] += ldt
        lamd[2 * j] = ldn
        lamd[2 * j + 1] = ldt
        d[3 * j] += ddn
        d[3 * j + 1] += ddtn
        d[3 * j + 2] += ddtt
        code[j] = c
        same = same and c == pattern[j] and c != TRANSITION
        if c != 0:
            act[n_act] = j
            n_act += 1
    return n_act, same


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _contact_residual(g, g_pred, W, wk, n_act):
    """r = -(g - g_pred - W Lambda) into wk.r (Lambda from ``_contact_laws``); returns |r|_2^2.
    Only the active pairs enter (the others have Lambda = 0). RT-safe."""
    r_, act, lam = wk.r, wk.act, wk.lam
    m = g.shape[0]
    for i in range(m):
        r_[i] = g_pred[i] - g[i]
    for a in range(n_act):  # W is symmetric: add its active rows (contiguous) scaled by Lambda
        j = act[a]
        ln = lam[2 * j]
        lt = lam[2 * j + 1]
        for i in range(m):
            r_[i] += W[2 * j, i] * ln + W[2 * j + 1, i] * lt
    res2 = 0.0
    for i in range(m):
        res2 += r_[i] * r_[i]
    return res2


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _factors_solve(wk, b, n):
    """b[:n] = J_aa^-1 b[:n] with the current slot's factors: their inverses, or for the
    transitions' slot (the last) the LU just factorised. RT-safe."""
    s = wk.slot[0]
    if s == wk.pattern.shape[0] - 1:
        _lu_solve(wk.LU, wk.piv[s], b, n)
    else:
        _inverse_solve(wk.Jinv[s], wk.piv[s], b, wk.ry, n)


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _fading_updates(W, wk, n_act):
    """Prepare rank-one updates of the current slot's factors for the active pairs whose only change
    since the factorisation is dLambda_t/dg_t (a fading tangential dashpot: its weight s is its
    step's own, 1.3), at most MAX_UPDATES; returns their number, or -1 if another entry changed or
    more pairs did (then the factors are refreshed).

    Such a change is J_aa' = J_aa - u delta e_c^T with u the active rows of W's column 2j+1 and c
    the pair's tangential column: Z = J_aa^-1 u per update (``_apply_updates`` then solves with J_aa'
    by the Woodbury identity). Z depends only on the factors and W, so each pair's row is kept with
    the factors (wk.z_ok): solving them in every step cost 0.49 us of the 3.30 us. Before, the
    factors were refreshed in every step with a fading pair active (95 % of the graded default's
    steps); with two updates at most, still in 9 % of the steps of the budget's Lyapunov run (three
    or more pairs fading at once), with four in none. RT-safe."""
    s = wk.slot[0]
    act, d, d_fact, upd, delta, Z, z_ok = wk.act, wk.d, wk.d_fact[s], wk.upd, wk.upd_delta, wk.Z[s], wk.z_ok[s]
    k = 0
    for b in range(n_act):
        j = act[b]
        if d[3 * j] != d_fact[3 * j] or d[3 * j + 1] != d_fact[3 * j + 1]:
            return -1
        if d[3 * j + 2] != d_fact[3 * j + 2]:
            if k == MAX_UPDATES:
                return -1
            upd[1 + k] = 2 * b + 1
            upd[1 + MAX_UPDATES + k] = j
            delta[k] = d[3 * j + 2] - d_fact[3 * j + 2]
            k += 1
    ma = 2 * n_act
    for u in range(k):
        j = upd[1 + MAX_UPDATES + u]
        if z_ok[j] == 0:
            for ra in range(ma):
                Z[j, ra] = W[2 * act[ra // 2] + ra % 2, 2 * j + 1]
            _factors_solve(wk, Z[j], ma)
            z_ok[j] = 1
    upd[0] = k
    return k


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _apply_updates(y, wk, ma):
    """y = J_aa'^-1 r from y = J_aa^-1 r (in place) for the rank-one updates J_aa' = J_aa -
    sum_k u_k delta_k e_ck^T of ``_fading_updates``, by the Woodbury identity
    y + Z t, (I - D V^T Z) t = D V^T y (D = diag(delta_k), V = [e_ck]); the k x k capacitance
    system (k <= MAX_UPDATES) by Gaussian elimination with partial pivoting. RT-safe."""
    k, upd, delta, Z, A = wk.upd[0], wk.upd, wk.upd_delta, wk.Z[wk.slot[0]], wk.cap
    if k == 0:
        return
    for a in range(k):
        ca = upd[1 + a]
        for b in range(k):
            A[a, b] = (1.0 if a == b else 0.0) - delta[a] * Z[upd[1 + MAX_UPDATES + b], ca]
        A[a, k] = delta[a] * y[ca]
    for c in range(k):
        pv = c
        for r in range(c + 1, k):
            if abs(A[r, c]) > abs(A[pv, c]):
                pv = r
        if pv != c:
            for cc in range(c, k + 1):
                tmp = A[c, cc]
                A[c, cc] = A[pv, cc]
                A[pv, cc] = tmp
        for r in range(c + 1, k):
            f = A[r, c] / A[c, c]
            for cc in range(c, k + 1):
                A[r, cc] -= f * A[c, cc]
    for c in range(k - 1, -1, -1):
        acc = A[c, k]
        for cc in range(c + 1, k):
            acc -= A[c, cc] * A[cc, k]
        A[c, k] = acc / A[c, c]
    for b in range(k):
        zb, t = upd[1 + MAX_UPDATES + b], A[b, k]
        for i in range(ma):
            y[i] += Z[zb, i] * t


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _jacobian_solve(r_, x, W, wk, n_act):
    """x = J^-1 r_ with the current slot's factors of the active block (``_contact_newton``'s partitioned
    solve): J_aa x_a = r_a by LU, then x_i = r_i + (W dLambda/dg)_ia x_a. r_ and x are (2p,)
    and distinct. RT-safe."""
    act, d, rhs = wk.act, wk.d, wk.ra
    m = r_.shape[0]
    ma = 2 * n_act
    for ra in range(ma):
        rhs[ra] = r_[2 * act[ra // 2] + ra % 2]
    _factors_solve(wk, rhs, ma)
    _apply_updates(rhs, wk, ma)
    for i in range(m):
        x[i] = r_[i]
    # x_i = r_i + (W dLambda/dg)_ia x_a (active rows are overwritten below; W symmetric)
    for b in range(n_act):
        j = act[b]
        cn = d[3 * j] * rhs[2 * b]
        cnt = d[3 * j + 1] * rhs[2 * b] + d[3 * j + 2] * rhs[2 * b + 1]
        for i in range(m):
            x[i] += W[2 * j, i] * cn + W[2 * j + 1, i] * cnt
    for b in range(n_act):
        j = act[b]
        x[2 * j] = rhs[2 * b]
        x[2 * j + 1] = rhs[2 * b + 1]


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _one_transition(code):
    """The pair that opens or closes within the step if it is the only one, else -1. RT-safe."""
    jt = -1
    for j in range(code.shape[0]):
        if code[j] == TRANSITION:
            if jt >= 0:
                return -1
            jt = j
    return jt


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _normal_mean(g0, g1, k_n, cn_h):
    """A pair's mean normal force over the step, spring (discrete gradient) plus dashpot, and its
    derivative in the end gap g1 [N, N/m] (``_normal_impulse`` + ``_interface_dashpot``'s normal
    part). RT-safe."""
    lam, dlam, _ = _normal_impulse(g0, g1, k_n)
    ldn, _, ddn, _, _ = _interface_dashpot(g0, g1, 0.0, 0.0, cn_h, 0.0, 1.0)  # tangential part unused
    return lam + ldn, dlam + ddn


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _transition_root(g_free, w_eff, g0, k_n, cn_h):
    """The end gap x [m] with x = g_free + w_eff Lambda_n(g0, x) and its Lambda_n [N] (``_normal_mean``).

    With w_eff > 0 and dLambda_n/dx <= 0 (the spring's discrete gradient and the dashpot both
    resist the gap's change), F(x) = x - g_free - w_eff Lambda_n(x) rises with slope >= 1, so its
    one root lies between x and x - F(x) for any x: Newton safeguarded by that bracket, to
    round-off. RT-safe."""
    x = g_free
    lam, dlam = _normal_mean(g0, x, k_n, cn_h)
    f = x - g_free - w_eff * lam
    lo = x - f if f > 0.0 else x
    hi = x if f > 0.0 else x - f
    for _ in range(60):
        if f == 0.0 or hi - lo <= 4.0 * ROUNDOFF * max(abs(lo), abs(hi)):
            break
        xn = x - f / (1.0 - w_eff * dlam)
        if not (lo < xn < hi):
            xn = 0.5 * (lo + hi)
        x = xn
        lam, dlam = _normal_mean(g0, x, k_n, cn_h)
        f = x - g_free - w_eff * lam
        if f > 0.0:
            hi = x
        else:
            lo = x
    return x, lam


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _transition_step(jt, g, dg, W, p, wk, n_act, inv_h):
    """Replace the Newton step dg by the exact solution for the one pair jt that opens or closes
    within the step, the other pairs staying in their pieces (docs/plant.md 2.3).

    Every pair law is affine within its piece except that pair's mean normal force Lambda_n(x) of
    its end gap x, a hyperbola (the discrete gradient across the contact's edge) on which plain
    Newton needs four to six iterations. With Lambda's Jacobian D at g, J = I - W D and
    z = J^-1 W e_n (e_n: pair jt's normal gap), the exact step is dg + z psi with psi the
    nonlinear remainder Lambda_n(x) - Lambda_n(g) - d_n (x - g_n). Eliminating the rest leaves
    one scalar equation x = g_free + w_eff Lambda_n(x), w_eff = z_n / (1 + d_n z_n) the pair's
    compliance with the others attached, solved by ``_transition_root``. Skipped (plain Newton
    step kept) unless w_eff > 0. RT-safe."""
    z, d, lam = wk.z, wk.d, wk.lam
    m = g.shape[0]
    n = 2 * jt
    _jacobian_solve(W[n], z, W, wk, n_act)  # W symmetric: its row is the column W e_n
    d_n = d[3 * jt]
    den = 1.0 + d_n * z[n]
    if not (den > 0.0 and z[n] > 0.0):
        return
    w_eff = z[n] / den
    coef = d_n * dg[n] / den
    lam_c = lam[n]
    g_free = g[n] + dg[n] - z[n] * coef - w_eff * lam_c
    _, lam_x = _transition_root(g_free, w_eff, wk.g0[n], p.k_n[jt], p.c_n[jt] * inv_h)
    s = (lam_x - lam_c) / den - coef
    for i in range(m):
        dg[i] += z[i] * s


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _reversals_to_stick(g, w_old, W, p, wk):
    """Take the stick piece for the next Newton step of every Jenkins pair whose slip reversed
    (its step, computed with slip in one direction, landed in slip in the other).

    Between slip + and slip - lies stick: a pair that reverses within the step is usually stuck
    at its end, and Newton with the two slip pieces alternates between them (two-cycles of 4+
    iterations, the tick's tail on the graded joint: docs/plant.md 6.4). The step is then
    computed with the stick piece's affine law M_t = Lambda_t + 1/2 (-k_t (g_t - w_old) - lambda_t1)
    instead of the slip linearisation: wk.r gets W e_t (M_t - Lambda_t), wk.d the stick entries
    (dLambda_t/dg_n 0, dLambda_t/dg_t -k_t/2 plus the dashpot's), wk.code stick (1). The residual
    and the law stay the true ones; only the step's piece changes. RT-safe."""
    code, pattern, d, r_, lam1, k_t = wk.code, wk.pattern[wk.slot[0]], wk.d, wk.r, wk.lam1, p.k_t
    m = g.shape[0]
    wt = 1.0 - p.law_w0   # weight of the end point's force (0.5: the trapezoid)
    for j in range(code.shape[0]):
        c, c_prev = code[j], pattern[j]
        if (c == 2 and c_prev == 3) or (c == 3 and c_prev == 2):
            dlam = wt * (-k_t[j] * (g[2 * j + 1] - w_old[j]) - lam1[2 * j + 1])
            for i in range(m):
                r_[i] += W[2 * j + 1, i] * dlam
            d[3 * j + 1] = 0.0
            d[3 * j + 2] -= wt * k_t[j]
            code[j] = 1


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _use_cached(wk):
    """Make current the slot whose factors belong to the pattern wk.code, if one does (True), else
    the least recently used slot, to be refactorised (False). A pattern with a pair in transition is
    never reused (its Jacobian entry moves with the end gap): it goes to the last slot, which is
    solved with its LU (not inverted) and evicts none of the others. RT-safe.

    A joint driven through a cycle visits the same patterns in turn: on the budget's Lyapunov run
    (graded default, 223.6 Hz, 105000 steps) 33400 lookups, 10040 of them transitions; of the
    23330 others 99.7 % find their pattern kept with 32 slots (least-recently-used), 44 % with 16.
    Factorisations 40420 -> 10100, nearly all of them transitions (docs/plant.md 2.3)."""
    code, pattern, last, key = wk.code, wk.pattern, wk.last_use, wk.key
    npair = code.shape[0]
    K = pattern.shape[0] - 1   # the last slot is the transitions'
    wk.slot[1] += 1
    h = 0
    for j in range(npair):
        if code[j] == TRANSITION:
            wk.slot[0] = K
            return False
        h = h * 31 + code[j] + 1   # wraps around in int64: a hash, equal patterns give equal keys
    for s in range(K):
        if key[s] != h:
            continue
        match = True
        for j in range(npair):
            if pattern[s, j] != code[j]:
                match = False
                break
        if match:
            wk.slot[0] = s
            last[s] = wk.slot[1]
            return True
    victim = 0
    for s in range(1, K):
        if last[s] < last[victim]:
            victim = s
    wk.slot[0] = victim
    last[victim] = wk.slot[1]
    key[victim] = h
    return False


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _contact_newton(g, g_pred, w_old, W, p, wk, inv_h):
    """Solve g = g_pred + W Lambda(g0, g, w_old) by Newton, starting from g (updated in place);
    inv_h = 1/h of the substep (the interface dashpots' mean force is c dg / h).

    Partitioned solve. Pairs open at both ends of the step have Lambda = 0 and zero Jacobian
    columns, so with the active pairs (a) first the Jacobian J = I - W dLambda/dg is

        [ J_aa  0 ] [d_a]   [r_a]      J_aa d_a = r_a                 (LU, 2 n_act square)
        [ J_ia  I ] [d_i] = [r_i]      d_i = r_i - J_ia d_a           (substitution)

    The LU factors of J_aa are kept with the pattern of states they were built for (wk.pattern)
    and the Jacobian entries they hold (wk.d_fact), FACTOR_SLOTS patterns at a time, and reused
    while the pattern holds or when it returns (``_use_cached``): entries that changed since (a
    fading dashpot's dLambda_t/dg_t, up to MAX_UPDATES pairs) are rank-one updates
    (``_fading_updates``); any other change (a Stribeck coefficient, more fading pairs) refreshes
    them. The law is affine within one pattern, so a step taken with the factors of pattern P that
    lands on a point whose pattern is still P is the exact solution (to round-off): the residual is
    not evaluated again there. Within the first PLAIN_ITER iterations a pair opening or closing
    within the step is solved exactly (``_transition_step``) and a pair whose slip reversed takes
    its stick piece (``_reversals_to_stick``); after them, if Newton has not converged (the active
    set cycles), steps are shortened by backtracking on |r|^2.
    Converged when |r|_2 <= p.tol + ROUNDOFF max|g_pred|. Returns the iterations used, or -1
    if that was not reached within p.max_iter. RT-safe.
    """
    act, d, code = wk.act, wk.d, wk.code
    r_, g_old, dg = wk.r, wk.g_old, wk.dg
    m = g.shape[0]
    npair = m // 2
    scale = 0.0
    for i in range(m):
        scale = max(scale, abs(g_pred[i]))
    tol = p.tol + ROUNDOFF * scale  # never ask for less than round-off of the gaps allows
    tol2 = tol * tol
    n_act, same = _contact_laws(g, w_old, p, wk, inv_h)
    res2 = _contact_residual(g, g_pred, W, wk, n_act)
    for it in range(p.max_iter):
        if res2 <= tol2:
            return it
        ma = 2 * n_act
        if it < PLAIN_ITER and p.iwan_k.shape[0] == 1:
            _reversals_to_stick(g, w_old, W, p, wk)
        if not same:
            same = _use_cached(wk)
        if not same or _fading_updates(W, wk, n_act) < 0:
            wk.upd[0] = 0
            s = wk.slot[0]
            LU, piv, d_fact, pattern, z_ok = wk.LU, wk.piv[s], wk.d_fact[s], wk.pattern[s], wk.z_ok[s]
            # --- J_aa = I - W_aa dLambda_a/dg_a, dLambda/dg block diagonal [[dnn, 0], [dtn, dtt]]
            for ra in range(ma):
                i = 2 * act[ra // 2] + ra % 2
                for b in range(n_act):
                    j = act[b]
                    LU[ra, 2 * b] = -(W[i, 2 * j] * d[3 * j] + W[i, 2 * j + 1] * d[3 * j + 1])
                    LU[ra, 2 * b + 1] = -W[i, 2 * j + 1] * d[3 * j + 2]
                LU[ra, ra] += 1.0
            _lu_factor(LU, piv, ma)
            if s < wk.pattern.shape[0] - 1:
                _triangular_inverses(LU, wk.Jinv[s], ma)
            for j in range(3 * npair):
                d_fact[j] = d[j]
            for j in range(npair):
                z_ok[j] = 0
            for j in range(npair):
                pattern[j] = code[j]
        _jacobian_solve(r_, dg, W, wk, n_act)
        if it < PLAIN_ITER and p.scheme == 0:   # the discrete gradient's exact transition
            jt = _one_transition(code)
            if jt >= 0:
                _transition_step(jt, g, dg, W, p, wk, n_act, inv_h)
        for i in range(m):
            g_old[i] = g[i]
            g[i] += dg[i]
        n_act, same = _contact_laws(g, w_old, p, wk, inv_h)
        if same:
            # the law is affine within one pattern and the step solved it exactly there
            return it + 1
        new2 = _contact_residual(g, g_pred, W, wk, n_act)
        if it >= PLAIN_ITER:
            alpha = 1.0
            while new2 >= res2 and alpha > 1e-6:
                alpha *= 0.5
                for i in range(m):
                    g[i] = g_old[i] + alpha * dg[i]
                n_act, same = _contact_laws(g, w_old, p, wk, inv_h)
                new2 = _contact_residual(g, g_pred, W, wk, n_act)
        res2 = new2
    return -1 if res2 > tol2 else p.max_iter


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _stribeck_update(qd, p, wk):
    """Friction coefficient of every pair for the coming substep (Stribeck, p.static_excess > 0):
    mu_eff_j = mu(v_j) (``frictionrt.plant.contact._stribeck_mu``) with v_j = G_t,j qd the pair's tangential
    surface velocity at the start of the substep [m/s]. Held over the substep (lagged), so the
    pair law stays piecewise affine and Newton exact. A slipping pair's changed coefficient changes
    its Jacobian entry, so the LU factors are refreshed (``_contact_newton`` compares wk.d with
    wk.d_fact). RT-safe."""
    G, mu, mu_eff = p.G, p.mu, wk.mu_eff
    s, v_s = p.static_excess, p.stribeck_v
    n = qd.shape[0]
    for j in range(mu.shape[0]):
        v = 0.0
        for i in range(n):
            v += G[2 * j + 1, i] * qd[i]
        mu_eff[j] = _stribeck_mu(mu[j], s, v, v_s)


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def refactor_kept(W, wk):
    """Rebuild the factor cache of wk from what a key frame keeps of it: each kept slot's pattern
    and Jacobian entries at its factorisation (wk.pattern, wk.d_fact; a slot of pattern -1 holds
    none). Each slot is factorised with ``_contact_newton``'s own expressions (J_aa = I - W_aa
    dLambda_a/dg_a over the pattern's active pairs in index order, ``_lu_factor``, and for all but
    the transitions' slot ``_triangular_inverses``), the current slot (wk.slot[0]) last so that
    wk.LU holds its LU, and every Woodbury row is marked stale (wk.z_ok = 0: recomputed from the
    factors when next needed, as in the run). The factors are functions of W, the pattern and
    d_fact only, so the cache equals the run's bit for bit (benchmarks/plant_cache_refactor.py).
    Returns the slots refactorised. Not RT-safe in time (a restart's work); no allocation."""
    pattern, d_fact, act = wk.pattern, wk.d_fact, wk.act
    K1, npair = pattern.shape
    cur = wk.slot[0]
    done = 0
    for t in range(K1 + 1):
        s = t if t < K1 else cur
        if (t < K1 and s == cur) or pattern[s, 0] == -1:
            continue
        n_act = 0
        for j in range(npair):
            if pattern[s, j] != 0:
                act[n_act] = j
                n_act += 1
        d = d_fact[s]
        LU = wk.LU
        ma = 2 * n_act
        for ra in range(ma):
            i = 2 * act[ra // 2] + ra % 2
            for b in range(n_act):
                j = act[b]
                LU[ra, 2 * b] = -(W[i, 2 * j] * d[3 * j] + W[i, 2 * j + 1] * d[3 * j + 1])
                LU[ra, 2 * b + 1] = -W[i, 2 * j + 1] * d[3 * j + 2]
            LU[ra, ra] += 1.0
        _lu_factor(LU, wk.piv[s], ma)
        if s < K1 - 1:
            _triangular_inverses(LU, wk.Jinv[s], ma)
        for j in range(npair):
            wk.z_ok[s, j] = 0
        done += 1
    return done


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _forget_factors(pattern):
    """Mark every slot's factors as belonging to no pattern (wk.pattern, (K, p)). RT-safe."""
    for s in range(pattern.shape[0]):
        for j in range(pattern.shape[1]):
            pattern[s, j] = -1


# inlined into _plant_step (two call sites): measured ~5 % faster per step at 9 and 33 pairs
@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH, inline="always")
def _substep(q, qd, w, g, en, qdd_a, lam_prev, rate, u_prev, F_exc, F_N1, p, wk, h, s2, W):
    """One substep of length h (modal compliance s2, Delassus matrix W), in place on the state
    views q, qd, w, g, the energy accumulators en = (E_fric, E_damp, W_exc, W_screw) and, for the
    generalized-alpha step (p.scheme 1), its algorithmic accelerations qdd_a (n_dyn,) and the pairs'
    mean normal gap rates over the last substep rate (p,) (both empty for the trapezoid). Returns
    the Newton iterations, or -1 with the state untouched if the contact solve did not converge.

    Generalized-alpha (Chung & Hulbert 1993) per stepped mode, the balance taken at the alpha
    point with the contact force af lambda_0 + (1 - af) lambda_1, lambda_0 the last step's end-point
    force (state lam_prev), lambda_1 = lambda(g1) the end-point law (``_normal_alpha`` with weight 0):

        m ((1 - am) a1 + am a0) + c ((1 - af) v1 + af v0) + omega^2 ((1 - af) q1 + af q0) = f + (G^T Lambda)_i
        q1 = q0 + h v0 + h^2 ((1/2 - beta) a0 + beta a1),   v1 = v0 + h ((1 - gamma) a0 + gamma a1)

    (m, c: p.m_step, p.c_step, period-matched as for the trapezoid: plant.model.alpha_period_matched),
    so q1 = q_pred + s2 G^T lambda_1 with s2 = (1 - af) h^2 beta / ((1 - am) m + (1 - af) (gamma h c +
    beta h^2 omega^2)), the form the contact solve takes. The quasi-static modes balance at the end
    point (theta = 0: q1 = Omega^-2 (f + G^T lambda_1)). a0 is the stored acceleration plus the jump of
    the held inputs since the last step, b (F - F_prev) / m. The tangential dashpots' weight is taken
    at the extrapolated end gap g_n0 + h rate. RT-safe.
    """
    b_exc, b_N1, f_const, omega2, G, c, k_t = p.b_exc, p.b_N1, p.f_const, p.omega2, p.G, p.c_step, p.k_t
    m_step = p.m_step
    q_pred, g_pred, g0, f_c, qdd_lin = wk.q_pred, wk.g_pred, wk.g0, wk.f_c, wk.qdd_lin
    lam1, lam, lamd, code, w_new = wk.lam1, wk.lam, wk.lamd, wk.code, wk.w_new
    n = q.shape[0]
    m = g.shape[0]
    npair = m // 2
    a2 = 2.0 / h
    # a quasi-static mode's surplus work per (omega^2 dq^2): (1 - theta) / (2 (1 + theta)) >= 0
    # (generalized-alpha: not booked; its balance's residual is the step's numerical dissipation)
    qs_loss = 0.5 * (1.0 - p.qs_theta) / (1.0 + p.qs_theta) if p.scheme == 0 else 0.0
    ga = p.scheme == 1
    am, af, beta, gamma = p.ga_am, p.ga_af, p.ga_beta, p.ga_gamma
    hb = 0.5 - beta
    # --- predictor: linear part with the contact forces off
    for i in range(n):
        f = b_exc[i] * F_exc + b_N1[i] * F_N1 + f_const[i]
        q_pred[i] = q[i] + s2[i] * (f + a2 * m_step[i] * qd[i] - omega2[i] * q[i])
    if ga:   # the stepped modes' generalized-alpha predictor (a loop of its own: the trapezoid's is unchanged)
        for i in range(p.n_dyn):   # the start point's contact force G_d^T lambda_0 (f_c is scratch until the corrector)
            f_c[i] = 0.0
        for r in range(m):
            lr = lam_prev[r]
            if lr != 0.0:
                for i in range(p.n_dyn):
                    f_c[i] += G[r, i] * lr
        s2a = 1.0 / (1.0 - af)   # s2 holds (1 - af) h^2 beta / D: the end force's share
        dF_exc, dF_N1 = F_exc - u_prev[0], F_N1 - u_prev[1]   # the held inputs' jump at this step's start
        for i in range(p.n_dyn):
            f = b_exc[i] * F_exc + b_N1[i] * F_N1 + f_const[i] + af * f_c[i]
            # the acceleration jumps with the inputs: without it the velocity update integrates the old
            # regime's over a share of the step (an O(h) error per jump: first order under held inputs)
            a0 = qdd_a[i] + (b_exc[i] * dF_exc + b_N1[i] * dF_N1) / m_step[i]
            qp = q[i] + h * qd[i] + h * h * hb * a0
            vp = qd[i] + h * (1.0 - gamma) * a0
            q_pred[i] = qp + s2a * s2[i] * (f - am * m_step[i] * a0 - c[i] * ((1.0 - af) * vp + af * qd[i])
                                            - omega2[i] * ((1.0 - af) * qp + af * q[i]))
    # g_pred = G q_pred. A quasi-static mode's predictor is q_pred = -theta q + s2 f (s2 omega^2 =
    # 1 + theta), and their gaps G_s q_s are the gaps g less the stepped modes' G_d q_d (the state's
    # g is G q to the Newton tolerance, 1e-18 m), so only the stepped modes' columns are read:
    #     g_pred = G_d (q_pred + theta q)_d - theta g + gq_exc F_exc + gq_N1 F_N1 + gq_const
    # (14 of the default's 61 columns; docs/plant.md 2.7)
    n_dyn, theta, gq_exc, gq_N1, gq_const, q_g = p.n_dyn, p.qs_theta, p.gq_exc, p.gq_N1, p.gq_const, wk.q_g
    for i in range(n_dyn):
        q_g[i] = q_pred[i] + theta * q[i]
    for r in range(m):
        acc = gq_exc[r] * F_exc + gq_N1[r] * F_N1 + gq_const[r] - theta * g[r]
        for i in range(n_dyn):
            acc += G[r, i] * q_g[i]
        g_pred[r] = acc
        g0[r] = g[r]
    gs = wk.gs
    for j in range(npair):   # the normal gap at which the tangential dashpots' weight is taken
        gs[j] = g0[2 * j] + h * rate[j] if ga else g0[2 * j]
    if p.static_excess > 0.0:
        _stribeck_update(qd, p, wk)
    # --- contact: g1 = g_pred + W Lambda(g0, g1), Newton started from g0
    it = _contact_newton(g, g_pred, w, W, p, wk, 1.0 / h)
    if it < 0:
        for r in range(m):
            g[r] = g0[r]
        return -1
    # --- corrector and energy bookkeeping
    dW_exc = 0.0
    dW_screw = 0.0
    dE_damp = 0.0
    for i in range(n):
        f_c[i] = 0.0
    for j in range(npair):  # modal contact force G^T Lambda over the active pairs (rows of G)
        if code[j] != 0:
            ln = lam[2 * j]
            lt = lam[2 * j + 1]
            for i in range(n):
                f_c[i] += G[2 * j, i] * ln + G[2 * j + 1, i] * lt
    for i in range(n_dyn if ga else 0):  # the stepped modes, generalized-alpha
        dq = q_pred[i] - q[i] + s2[i] * f_c[i]
        a0 = qdd_a[i] + (b_exc[i] * (F_exc - u_prev[0]) + b_N1[i] * (F_N1 - u_prev[1])) / m_step[i]
        a1 = (dq - h * qd[i] - h * h * hb * a0) / (h * h * beta)
        qd_new = qd[i] + h * ((1.0 - gamma) * a0 + gamma * a1)
        qdd_a[i] = a1
        v_mid = 0.5 * (qd[i] + qd_new)
        dE_damp += h * c[i] * v_mid * v_mid
        dW_exc += b_exc[i] * dq
        f_screw = b_N1[i] * F_N1 + f_const[i]
        dW_screw += f_screw * dq
        q[i] += dq
        qd[i] = qd_new
        qdd_lin[i] = (b_exc[i] * F_exc + f_screw - c[i] * qd_new - omega2[i] * q[i]) / m_step[i]
    for i in range(0 if ga else n_dyn):  # the stepped modes, trapezoid
        dq = q_pred[i] - q[i] + s2[i] * f_c[i]
        qd_new = a2 * dq - qd[i]
        v_mid = 0.5 * (qd[i] + qd_new)
        dE_damp += h * c[i] * v_mid * v_mid
        dW_exc += b_exc[i] * dq
        f_screw = b_N1[i] * F_N1 + f_const[i]
        dW_screw += f_screw * dq
        q[i] += dq
        qd[i] = qd_new
        qdd_lin[i] = (b_exc[i] * F_exc + f_screw - c[i] * qd_new - omega2[i] * q[i]) / m_step[i]
    for i in range(n_dyn, n):  # the quasi-static ones keep qd = 0 (and qdd_lin = 0: the outputs skip them)
        dq = q_pred[i] - q[i] + s2[i] * f_c[i]
        # q1 = (1 + theta) q_static - theta q0: the load does qs_loss omega^2 dq^2 more work than the
        # mode's potential energy gains (booked as damping, >= 0)
        dE_damp += qs_loss * omega2[i] * dq * dq
        dW_exc += b_exc[i] * dq
        dW_screw += (b_N1[i] * F_N1 + f_const[i]) * dq
        q[i] += dq
    dE_fric = 0.0
    kf = p.iwan_k
    ne = kf.shape[0]
    for j in range(npair):
        if ne == 1:
            f_t0 = k_t[j] * (g0[2 * j + 1] - w[j])
            dE_fric += 0.5 * (f_t0 - lam1[2 * j + 1]) * (w_new[j] - w[j])
            w[j] = w_new[j]
        else:  # per element: 1/2 (f_i0 + f_i1) dw_i, f_i = k_i (g_t - w_i)
            for i in range(j * ne, j * ne + ne):
                k_i = k_t[j] * kf[i - j * ne]
                dE_fric += 0.5 * k_i * ((g0[2 * j + 1] - w[i]) + (g[2 * j + 1] - w_new[i])) * (w_new[i] - w[i])
                w[i] = w_new[i]
        # the interface dashpots dissipate -lamd . dg >= 0
        dE_damp -= lamd[2 * j] * (g[2 * j] - g0[2 * j]) + lamd[2 * j + 1] * (g[2 * j + 1] - g0[2 * j + 1])
    if ga:
        for j in range(npair):
            rate[j] = (g[2 * j] - g0[2 * j]) / h
            lam_prev[2 * j] = lam[2 * j] if code[j] != 0 else 0.0
            lam_prev[2 * j + 1] = lam[2 * j + 1] if code[j] != 0 else 0.0
        u_prev[0] = F_exc
        u_prev[1] = F_N1
    en[0] += dE_fric
    en[1] += dE_damp
    en[2] += F_exc * dW_exc
    en[3] += dW_screw
    return it


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _plant_step(k, x, u, p, x_next, y, wk):
    """Advance the plant over one controller step (p.substeps substeps, inputs held).

    A substep whose contact solve does not converge (the nonsmooth Newton can stall at a
    pair's first touch) is redone as p.fine_split substeps of length h / p.fine_split; the
    count of such fallbacks is an output.

    Parameters
    ----------
    k : int64 tick (the plant is time-invariant; kept for the uniform step signature)
    x : state at t_k (read only);  x_next : state at t_{k+1} (written)
    u : (2,) inputs held over [t_k, t_{k+1}): u[0] excitation force F_exc [N], u[1] F_N1 [N]
    p : PlantParams;  wk : PlantWork
    y : outputs at t_{k+1}, layout of ``PlantModel.output_labels``: w, w', w'' at points
        [m, m/s, m/s^2]; u_rel [m], v_rel [m/s]; g_n, g_t [m], f_n, f_t [N] per pair;
        E_fric, E_damp, W_exc, W_screw [J]; Newton iterations (sum; -1 if any failed);
        substep fallbacks; abar at points [m/s^2]: the mean acceleration over the step,
        (w'(t_k+1) - w'(t_k)) / dt, which is what an anti-aliased accelerometer sees (the
        end-point accelerations carry the contact's impacts and unresolved modes as sampled
        spikes: their mean is not the mean of the motion, +1.5 m/s^2 at the tip in a 5 N run);
        per bolt its separation g_b [m] and force F_b [N] (the adaptive screw's F_N1 with the held
        stack force u[1]); the adaptive bolt's separation force k (g - g_ref) [N].

    Returns the Newton iterations summed over the substeps, or -1 if a solve did not converge
    even on the fine substeps. RT-safe.
    """
    out_rows, out_G, qdd_lin, lam1, lamd, pattern = p.out_rows, p.out_G, wk.qdd_lin, wk.lam1, wk.lamd, wk.pattern
    n = p.c.shape[0]
    m = p.G.shape[0]
    npair = m // 2
    n_w = npair * p.iwan_k.shape[0]
    for i in range(x.shape[0]):
        x_next[i] = x[i]
    q = x_next[0:n]
    qd = x_next[n:2 * n]
    w = x_next[2 * n:2 * n + n_w]
    g = x_next[2 * n + n_w:2 * n + n_w + m]
    e = 2 * n + n_w + m
    en = x_next[e:e + N_ENERGY]
    e += N_ENERGY
    n_acc = p.n_dyn if p.scheme == 1 else 0   # generalized-alpha: accelerations, end forces, normal gap rates
    n_lam = m if p.scheme == 1 else 0
    qdd_a = x_next[e:e + n_acc]
    lam_prev = x_next[e + n_acc:e + n_acc + n_lam]
    o_r = e + n_acc + n_lam
    n_r = npair if p.scheme == 1 else 0
    rate = x_next[o_r:o_r + n_r]
    u_prev = x_next[o_r + n_r:o_r + n_r + (2 if p.scheme == 1 else 0)]
    F_exc, F_N1 = u[0], u[1]
    iters = 0
    fallbacks = 0
    for _ in range(p.substeps):
        it = _substep(q, qd, w, g, en, qdd_a, lam_prev, rate, u_prev, F_exc, F_N1, p, wk, p.h, p.s2, p.W)
        if it < 0:
            fallbacks += 1
            _forget_factors(pattern)  # the kept factors belong to W, not W_fine
            it = 0
            for _ in range(p.fine_split):
                it_f = _substep(q, qd, w, g, en, qdd_a, lam_prev, rate, u_prev, F_exc, F_N1, p, wk,
                                p.h_fine, p.s2_fine, p.W_fine)
                it = -1 if (it_f < 0 or it < 0) else it + it_f
            _forget_factors(pattern)
        iters = -1 if (it < 0 or iters < 0) else iters + it
    # --- outputs at t_{k+1}; accelerations from the equation of motion at the end point
    n_rows = p.out_rows.shape[0]
    n_pts = n_rows - 1
    inv_dt = 1.0 / (p.h * p.substeps)
    o_bar = 3 * (n_rows - 1) + 2 + 4 * npair + N_ENERGY + 2
    for r in range(n_rows):
        a_x = 0.0
        a_v = 0.0
        a_a = 0.0
        v_start = 0.0
        for i in range(n):
            a_x += out_rows[r, i] * q[i]
        for i in range(p.n_dyn):  # the quasi-static modes have qd = qdd_lin = 0
            a_v += out_rows[r, i] * qd[i]
            a_a += out_rows[r, i] * qdd_lin[i]
            v_start += out_rows[r, i] * x[n + i]
        for j in range(m):
            a_a += out_G[r, j] * (lam1[j] + lamd[j])
        if r < n_pts:
            y[r] = a_x
            y[n_pts + r] = a_v
            y[2 * n_pts + r] = a_a
            y[o_bar + r] = (a_v - v_start) * inv_dt
        else:
            y[3 * n_pts] = a_x
            y[3 * n_pts + 1] = a_v
    o = 3 * n_pts + 2
    for j in range(npair):
        y[o + j] = g[2 * j]
        y[o + npair + j] = g[2 * j + 1]
        y[o + 2 * npair + j] = lam1[2 * j]
        y[o + 3 * npair + j] = -lam1[2 * j + 1]
    o += 4 * npair
    for i in range(N_ENERGY):
        y[o + i] = en[i]
    y[o + N_ENERGY] = iters
    y[o + N_ENERGY + 1] = fallbacks
    # --- the bolts at t_{k+1}: separation g_b and force F_b = F_pre + k_b (g_b - g_ref_b), the
    # adaptive one's preload the held input F_N1; last its separation force k (g - g_ref) alone
    bolt_rows, bolt_k, bolt_ref = p.bolt_rows, p.bolt_k, p.bolt_ref
    o = o_bar + n_pts
    nb = bolt_k.shape[0]
    y[o + 2 * nb] = 0.0   # dF_N1 of a structure without an adaptive screw (else overwritten below)
    for b in range(nb):
        gb = 0.0
        for i in range(n):
            gb += bolt_rows[b, i] * q[i]
        dF = bolt_k[b] * (gb - bolt_ref[b])
        y[o + 2 * b] = gb
        y[o + 2 * b + 1] = p.bolt_F[b] + dF + (F_N1 if b == p.bolt_adaptive else 0.0)
        if b == p.bolt_adaptive:
            y[o + 2 * nb] = dF
    return iters
