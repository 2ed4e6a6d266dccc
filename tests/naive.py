"""Plain NumPy references for the numba kernels (after stumpy's ``tests/naive.py``).

Written from the equations in the docstrings of ``plant/contact.py`` and ``plant/newmark.py``
(and SPEC section 2), not from the kernels' code: vectorised over pairs, with different (but
mathematically equal) formulas where a choice exists, a dense Newton on the full contact
system instead of the kernel's partitioned solve with cached LU, and the outputs filled by
label from ``PlantModel.output_labels()``/``state_slots()`` rather than by index arithmetic.
Nothing here imports from ``frictionrt.plant.contact`` or ``frictionrt.plant.newmark``; the references are slow and
allocate freely.
"""
from __future__ import annotations

import numpy as np

OPEN, STICK, SLIP_POS, SLIP_NEG = 0, 1, 2, 3  # contact state of a pair at the end point


# --- one pair ---------------------------------------------------------------------------------

def jenkins_pair(g_n, g_t, w_old, k_n, k_t, mu):
    """End-point pair force of the penalty + Jenkins law, vectorised over pairs.

    Law (SPEC section 2): f_n = k_n max(0, -g_n); the spring force is k_t (g_t - w) with the
    slider w moving only when |k_t (g_t - w_old)| would exceed mu f_n; an open pair (g_n >= 0)
    carries nothing and its spring relaxes (w = g_t). The force on the upper body is
    lambda = (f_n, -f_t).

    Returns (lam_n, lam_t, w_new, dlam_n/dg_n, dlam_t/dg_n, dlam_t/dg_t, state) as arrays,
    ``state`` in {OPEN, STICK, SLIP_POS, SLIP_NEG}.
    """
    g_n, g_t, w_old, k_n, k_t, mu = np.broadcast_arrays(*(np.asarray(a, dtype=float)
                                                         for a in (g_n, g_t, w_old, k_n, k_t, mu)))
    closed = g_n < 0.0
    f_n = np.where(closed, k_n * np.maximum(-g_n, 0.0), 0.0)
    cap = mu * f_n                                   # Coulomb limit [N]
    trial = k_t * (g_t - w_old)                      # spring force if the slider stays [N]
    stick = closed & (np.abs(trial) <= cap)
    slip = closed & ~stick
    s = np.sign(trial)
    f_t = np.where(stick, trial, np.where(slip, s * cap, 0.0))
    # the slider takes up the excess of the trial force over the limit: w = w_old + (f* - f_t)/k_t
    w_new = np.where(closed, w_old + (trial - f_t) / k_t, g_t)
    # derivatives of lam = (f_n, -f_t): stick -f_t = -k_t (g_t - w_old); slip -f_t = s mu k_n g_n
    d_nn = np.where(closed, -k_n, 0.0)
    d_tn = np.where(slip, mu * k_n * s, 0.0)
    d_tt = np.where(stick, -k_t, 0.0)
    state = np.where(~closed, OPEN, np.where(stick, STICK, np.where(s > 0, SLIP_POS, SLIP_NEG)))
    return f_n, -f_t, w_new, d_nn, d_tn, d_tt, state


def normal_potential(g, k_n):
    """V(g) = 1/2 k_n min(0, g)^2 [J]."""
    return 0.5 * k_n * np.minimum(0.0, g) ** 2


def normal_impulse(g0, g1, k_n):
    """Mean normal force over a step: the discrete gradient Lambda_n = -(V(g1) - V(g0)) / (g1 - g0).

    Evaluated without cancellation through m = min(0, g):
        V(g1) - V(g0) = 1/2 k_n (m1 + m0)(m1 - m0),  so  Lambda_n = -1/2 k_n (m1 + m0) rho,
        rho = (m1 - m0) / (g1 - g0)  (1 closed at both ends, 0 open at both, else the
        fraction of the step spent in contact).
    Returns (Lambda_n, dLambda_n/dg1, True where the pair opens or closes in the step).
    """
    g0, g1, k_n = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (g0, g1, k_n)))
    c0, c1 = g0 < 0.0, g1 < 0.0
    moved = c0 != c1
    m0, m1 = np.minimum(g0, 0.0), np.minimum(g1, 0.0)
    dg = np.where(moved, g1 - g0, 1.0)
    rho = np.where(moved, (m1 - m0) / dg, np.where(c0, 1.0, 0.0))
    lam = -0.5 * k_n * (m1 + m0) * rho
    # derivative, differentiated by hand per case:
    #   closed-closed  Lambda = -k/2 (g0 + g1)        -> -k/2
    #   opening        Lambda =  k/2 g0^2 / (g1 - g0)  -> -k/2 g0^2 / (g1 - g0)^2
    #   closing        Lambda = -k/2 g1^2 / (g1 - g0)  -> -k/2 g1 (g1 - 2 g0) / (g1 - g0)^2
    d = np.where(c0 & c1, -0.5 * k_n, 0.0)
    d = np.where(moved & c0, -0.5 * k_n * g0 ** 2 / dg ** 2, d)
    d = np.where(moved & c1, -0.5 * k_n * g1 * (g1 - 2.0 * g0) / dg ** 2, d)
    return lam, d, moved


# --- all pairs over one step ------------------------------------------------------------------

def interface_dashpot(gn0, gn1, gt0, gt1, cn_h, ct_h, depth):
    """Mean dashpot forces over a step, from their definition (vectorised over pairs): the normal
    one acts on the change of penetration p = min(0, g_n); the tangential one on the change of
    g_t, weighted by s = S(min(1, -p0 / depth)), S(x) = 3x^2 - 2x^3 (penetration at the start).
    Returns (Ld_n, Ld_t, dLd_n/dg_n1, dLd_t/dg_n1, dLd_t/dg_t1)."""
    p0, p1 = np.minimum(0.0, gn0), np.minimum(0.0, gn1)
    in1 = (gn1 < 0.0).astype(float)                 # dp1 / dg_n1
    x = np.minimum(1.0, -p0 / depth)
    s = 3.0 * x**2 - 2.0 * x**3
    dgt = gt1 - gt0
    return -cn_h * (p1 - p0), -ct_h * s * dgt, -cn_h * in1, np.zeros_like(s), -ct_h * s


def mean_contact_force(g0, g1, w0, k_n, k_t, mu, cn_h=0.0, ct_h=0.0, depth=1.0):
    """Mean contact force Lambda over a step and its Jacobian wrt g1 (all pairs).

    g0, g1: (2p,) gaps (g_n, g_t interleaved) at the start and end; w0: (p,) slider at the start.
    Lambda_n = discrete gradient of the normal potential; Lambda_t = mean of the tangential
    spring forces at the two ends, -(k_t (g0_t - w0) + f_t(g1)) / 2 (the Jenkins force is
    always its spring's force k_t (g_t - w)); plus the interface dashpots (c/h = cn_h, ct_h).
    Returns (Lam (2p,), dLam/dg1 (2p, 2p), lam1 (2p,) end-point spring/slider force, w1 (p,),
    state (p,), moved (p,) True where the pair opens or closes within the step, Ld (2p,) the
    dashpot part of Lam).
    """
    gn0, gt0, gn1, gt1 = g0[0::2], g0[1::2], g1[0::2], g1[1::2]
    Ln, dLn, moved = normal_impulse(gn0, gn1, k_n)
    ln1, lt1, w1, _, dtn, dtt, state = jenkins_pair(gn1, gt1, w0, k_n, k_t, mu)
    lt0 = -k_t * (gt0 - w0)
    m = len(g1)
    Ldn, Ldt, dDnn, dDtn, dDtt = interface_dashpot(gn0, gn1, gt0, gt1, cn_h, ct_h, depth)
    Ld = np.empty(m)
    Ld[0::2], Ld[1::2] = Ldn, Ldt
    Lam = np.empty(m)
    Lam[0::2] = Ln + Ldn
    Lam[1::2] = 0.5 * (lt0 + lt1) + Ldt
    J = np.zeros((m, m))
    i = np.arange(m // 2)
    J[2 * i, 2 * i] = dLn + dDnn
    J[2 * i + 1, 2 * i] = 0.5 * dtn + dDtn
    J[2 * i + 1, 2 * i + 1] = 0.5 * dtt + dDtt
    lam1 = np.empty(m)
    lam1[0::2], lam1[1::2] = ln1, lt1
    return Lam, J, lam1, w1, state, moved, Ld


def contact_residual(g1, g0, g_pred, w0, W, k_n, k_t, mu, cn_h=0.0, ct_h=0.0, depth=1.0):
    """R(g1) = g1 - g_pred - W Lambda(g0, g1, w0) [m] and its Jacobian I - W dLambda/dg1."""
    Lam, D, *_ = mean_contact_force(g0, g1, w0, k_n, k_t, mu, cn_h, ct_h, depth)
    return g1 - g_pred - W @ Lam, np.eye(len(g1)) - W @ D


def solve_contact(g0, g_pred, w0, W, k_n, k_t, mu, cn_h=0.0, ct_h=0.0, depth=1.0, max_iter=200):
    """Solve g1 = g_pred + W Lambda(g0, g1, w0) by a dense damped Newton on the full 2p system.

    Seeded from the predictor g_pred (contact off); each step is a numpy.linalg.solve with
    the full Jacobian, halved while it does not reduce |R|; iterated until |R| stops falling,
    i.e. to round-off. Returns (g1, |R|_2).
    """
    g = np.array(g_pred, dtype=float)
    R, J = contact_residual(g, g0, g_pred, w0, W, k_n, k_t, mu, cn_h, ct_h, depth)
    r = np.linalg.norm(R)
    for _ in range(max_iter):
        if r == 0.0:
            break
        d = -np.linalg.solve(J, R)
        a = 1.0
        while True:
            g_try = g + a * d
            R_try, J_try = contact_residual(g_try, g0, g_pred, w0, W, k_n, k_t, mu, cn_h, ct_h, depth)
            r_try = np.linalg.norm(R_try)
            if r_try < r or a < 1e-12:
                break
            a *= 0.5
        if r_try >= r:
            break  # no decrease even along a tiny step: |R| is at its round-off floor
        g, R, J, r = g_try, R_try, J_try, r_try
    return g, r


# --- the plant step ---------------------------------------------------------------------------

def period_matched(P):
    """(m, c) of the stepped modes [-, 1/s]: where the plant period-matches its modes (some
    P.m_step != 1), the modal mass (omega / omega_d)^2 with omega_d = (2/h) tan(omega h / 2) and the
    damping 2 zeta omega^2 / omega_d x omega h / sin(omega h), zeta = c / (2 omega), for the
    dynamic modes with 0 < omega h < 1 at the substep h = P.h; else 1 and c."""
    omega = np.sqrt(P.omega2)
    x = omega * P.h
    match = (P.dyn > 0) & (omega > 0) & (x < 1.0) & np.any(P.m_step != 1.0)
    x = np.where(match, x, 1.0)
    omega_d = 2.0 / P.h * np.tan(x / 2)
    zeta = P.c / (2.0 * np.where(match, x / P.h, 1.0))
    return (np.where(match, (x / P.h / omega_d) ** 2, 1.0),
            np.where(match, 2.0 * zeta * (x / P.h) ** 2 / omega_d * x / np.sin(x), P.c))


def newmark_compliance(P, h):
    """s2 = 2 / (omega^2 + (2/h) c + 4 m/h^2) per dynamic mode (m, c: ``period_matched``),
    (1 + theta) / omega^2 per quasi-static one (P.dyn = 0) [s^2], and W = G diag(s2) G^T [m/N]."""
    dyn = P.dyn > 0
    m, c = period_matched(P)
    s2 = np.where(dyn, 2.0 / (P.omega2 + (2.0 / h) * c + 4.0 * m / h**2),
                  (1.0 + P.qs_theta) / np.where(dyn, 1.0, P.omega2))
    return s2, (P.G * s2) @ P.G.T


def newmark_substep(q, qd, w, g, E, F_exc, F_N1, P, h):
    """One substep of length h of mean-form average-acceleration Newmark (see ``plant_step``).
    Returns the new (q, qd, w, g), the end-point contact force lambda1 and diagnostics."""
    s2, W = newmark_compliance(P, h)
    m, c = period_matched(P)
    f_screw = P.b_N1 * F_N1 + P.f_const
    f = P.b_exc * F_exc + f_screw
    dyn = P.dyn > 0
    # dynamic modes: the mean form; quasi-static ones: (1 + theta) x the static response to the
    # held load, minus theta q0
    q_pred = np.where(dyn, q + s2 * (f + (2.0 / h) * m * qd - P.omega2 * q), s2 * f - P.qs_theta * q)
    g_pred = P.G @ q_pred
    cn_h, ct_h = P.c_n / h, P.c_t / h
    g1, res = solve_contact(g, g_pred, w, W, P.k_n, P.k_t, P.mu, cn_h, ct_h, P.dashpot_depth)
    Lam, _, lam1, w1, state, moved, Ld = mean_contact_force(g, g1, w, P.k_n, P.k_t, P.mu, cn_h, ct_h,
                                                             P.dashpot_depth)
    q1 = q_pred + s2 * (P.G.T @ Lam)
    dq = q1 - q
    qd1 = np.where(dyn, (2.0 / h) * dq - qd, 0.0)
    f_t0 = P.k_t * (g[1::2] - w)          # spring force at the start
    f_t1 = -lam1[1::2]                     # and at the end
    E["E_fric"] += float(np.sum(0.5 * (f_t0 + f_t1) * (w1 - w)))
    # the quasi-static modes' surplus work: load (= omega^2 (q1 + theta q0) / (1 + theta)) . dq
    # minus the potential's gain
    load = P.omega2 * (q1 + P.qs_theta * q) / (1.0 + P.qs_theta)
    surplus = np.where(dyn, 0.0, load * dq - 0.5 * P.omega2 * (q1**2 - q**2))
    E["E_damp"] += float(h * np.sum(c * (0.5 * (qd + qd1)) ** 2)) - float(Ld @ (g1 - g)) + float(surplus.sum())
    E["W_exc"] += F_exc * float(P.b_exc @ dq)
    E["W_screw"] += float(f_screw @ dq)
    info = {"state": state, "moved": moved, "res": res, "gq_mismatch": float(np.max(np.abs(P.G @ q1 - g1)))}
    return q1, qd1, w1, g1, lam1 + Ld, lam1, info


def plant_step(x, u, P, slots, labels, split=None):
    """One controller step of the plant (P.substeps substeps, inputs held), mean-form
    average-acceleration Newmark on the decoupled modes.

    Per substep of length h, with f = b_exc F_exc + b_N1 F_N1 + f_const held:
        s2     = 2 / (omega^2 + (2/h) c + 4 m/h^2),  W = G diag(s2) G^T   (computed here;
                 m, c the period-matched modal mass and damping, ``period_matched``)
        q_pred = q0 + s2 (f + (2/h) m qd0 - omega^2 q0)          (contact off)
        g1     = solve of g1 = G q_pred + W Lambda(g0, g1, w0)
        q1     = q_pred + s2 G^T Lambda,   qd1 = (2/h)(q1 - q0) - qd0
        E_fric  += sum 1/2 (f_t0 + f_t1)(w1 - w0)      f_t = k_t (g_t - w), spring force
        E_damp  += h sum c v_mid^2 + (interface dashpots) -Ld . (g1 - g0),  v_mid = (qd0 + qd1)/2
        W_exc   += F_exc b_exc . dq,  W_screw += (b_N1 F_N1 + f_const) . dq
    ``split`` (one int per substep, default all 1) redoes a substep as that many substeps of
    h / split: the kernel's fallback when its Newton fails, which the reference cannot see, so
    the caller passes it.
    Outputs at the end point, by label: w, w' at the points and u_rel, v_rel from out_rows;
    accelerations out_rows (f - c qd1 - omega^2 q1 + G^T (lambda1 + Ld)) / m; mean accelerations
    abar = out_rows (qd1 - qd0) / dt over the controller step; gaps, f_n = lambda1_n,
    f_t = -lambda1_t per pair; the energies. Labels not listed here (solver counters) are NaN.

    Returns (x_next, y, info) with info a dict of lists of per-substep diagnostics (pair
    states, transitions, reference residual, |G q1 - g1|).
    """
    F_exc, F_N1 = float(u[0]), float(u[1])
    q = x[slots["q"]].copy()
    qd = x[slots["qd"]].copy()
    qd_start = qd.copy()
    w = x[slots["w"]].copy()
    g = x[slots["g"]].copy()
    E = {nm: float(x[slots[nm]][0]) for nm in ("E_fric", "E_damp", "W_exc", "W_screw")}
    split = [1] * P.substeps if split is None else list(split)
    info = {"state": [], "moved": [], "res": [], "gq_mismatch": []}
    for n_sub in split:
        for _ in range(n_sub):
            q, qd, w, g, lam_acc, lam1, inf = newmark_substep(q, qd, w, g, E, F_exc, F_N1, P, P.h / n_sub)
            for key, values in info.items():
                values.append(inf[key])
    x_next = np.array(x, dtype=float)
    x_next[slots["q"]], x_next[slots["qd"]], x_next[slots["w"]], x_next[slots["g"]] = q, qd, w, g
    for nm, val in E.items():
        x_next[slots[nm]] = val

    f = P.b_exc * F_exc + P.b_N1 * F_N1 + P.f_const
    # modal acceleration at the end point (none for a quasi-static mode)
    m, c = period_matched(P)
    acc = np.where(P.dyn > 0, (f - c * qd - P.omega2 * q + P.G.T @ lam_acc) / m, 0.0)
    disp, vel, accel = P.out_rows @ q, P.out_rows @ qd, P.out_rows @ acc
    names = [nm for nm, _ in labels]
    y = np.full(len(names), np.nan)
    pts = [nm[2:] for nm in names if nm.startswith("w_")]
    for i, s in enumerate(pts):
        y[names.index(f"w_{s}")] = disp[i]
        y[names.index(f"v_{s}")] = vel[i]
        y[names.index(f"a_{s}")] = accel[i]
        y[names.index(f"abar_{s}")] = P.out_rows[i] @ (qd - qd_start) / (P.h * P.substeps)
    y[names.index("u_rel")] = disp[len(pts)]
    y[names.index("v_rel")] = vel[len(pts)]
    for j in range(len(w)):
        y[names.index(f"g_n_{j}")] = g[2 * j]
        y[names.index(f"g_t_{j}")] = g[2 * j + 1]
        y[names.index(f"f_n_{j}")] = lam1[2 * j]
        y[names.index(f"f_t_{j}")] = -lam1[2 * j + 1]
    for nm, val in E.items():
        y[names.index(nm)] = val
    # bolts: separation and force F_pre + k (g - g_ref), the adaptive one's preload the input F_N1
    gb = P.bolt_rows @ q
    dF = P.bolt_k * (gb - P.bolt_ref)
    force = P.bolt_F + dF
    force[P.bolt_adaptive] += F_N1
    bolt_g = [nm for nm in names if nm.startswith("g_bolt_")]
    bolt_f = [nm for nm in names if nm == "F_N1" or nm.startswith("F_bolt_")]
    for b, (ng, nf) in enumerate(zip(bolt_g, bolt_f)):
        y[names.index(ng)] = gb[b]
        y[names.index(nf)] = force[b]
    y[names.index("dF_N1")] = dF[P.bolt_adaptive]
    return x_next, y, info


def simulate(x0, U, P, slots, labels, splits=None):
    """Step ``plant_step`` over the rows of U = (F_exc, F_N1) (``splits[k]``: the ``split`` of
    step k). Returns (X (n+1, nx), Y, infos)."""
    X = [np.array(x0, dtype=float)]
    Y, infos = [], []
    for k in range(len(U)):
        xn, y, info = plant_step(X[-1], U[k], P, slots, labels, None if splits is None else splits[k])
        X.append(xn)
        Y.append(y)
        infos.append(info)
    return np.array(X), np.array(Y), infos


# --- describing functions (plant/describing.py) -----------------------------------------------

def jenkins_df(a, k, q):
    """(k_eq, dk_eq/da) of a Jenkins element (spring k [N/m], slip force q [N]) at amplitudes a [m]:
    k while k a <= q, else with cos(theta*) = 1 - 2 q / (k a) (Krack & Gross 2019, sec. 2.3)
    k_eq = (k / pi)(theta* - sin(2 theta*) / 2) + i (4 q / (pi a))(1 - q / (k a)),
    dk_eq/da = -(4 q / (pi a^2)) sin(theta*) + i (4 q / pi)(2 q / (k a^3) - 1 / a^2)."""
    a = np.asarray(a, dtype=float)
    slip = k * a > q
    s = np.where(slip, a, 1.0)
    th = np.arccos(np.clip(1.0 - 2.0 * q / (k * s), -1.0, 1.0))
    keq = np.where(slip, (k / np.pi) * (th - 0.5 * np.sin(2.0 * th))
                   + 1j * (4.0 * q / (np.pi * s)) * (1.0 - q / (k * s)), k + 0j)
    dkeq = np.where(slip, -(4.0 * q / (np.pi * s * s)) * np.sin(th)
                    + 1j * (4.0 * q / np.pi) * (2.0 * q / (k * s ** 3) - 1.0 / s ** 2), 0j)
    return keq, dkeq


def pair_df(a, k_t, q, kf, qf):
    """The Iwan element's (k_eq, dk_eq/da): the sum of its Jenkins elements k_i = kf_i k_t, q_i = qf_i q."""
    parts = [jenkins_df(a, fk * k_t, fq * q) for fk, fq in zip(kf, qf)]
    return sum(p[0] for p in parts), sum(p[1] for p in parts)
