"""Node-to-node contact law of one pair (SPEC section 2): bilinear penalty normal contact and
a Jenkins tangential element (spring k_t in series with a Coulomb slider, slider position w).

Sign convention: gaps g = (g_n, g_t) are the upper body's surface point minus the lower body's
(g_n > 0 open). The pair force lambda = (lambda_n, lambda_t) acts on the upper body along the
gap directions (and its opposite on the lower body), so its generalised force is G^T lambda.

    f_n      = k_n max(0, -g_n)                       normal force (compression >= 0) [N]
    f*       = k_t (g_t - w_old)                      trial tangential spring force [N]
    stick:   |f*| <= mu f_n  ->  f_t = f*,  w = w_old
    slip:    f_t = mu f_n sign(f*),  w = g_t - f_t / k_t   (return mapping)
    open:    f_n = f_t = 0,  w = g_t                  (spring relaxed)
    lambda_n = f_n,  lambda_t = -f_t

Iwan element (``_iwan_pair``, plant.interface.iwan_spread a > 0): N Jenkins elements in
parallel instead of one, element i with stiffness k_i = k_t / N and slip limit

    q_i = (mu f_n / N) (1 + a (2 (i + 1/2) / N - 1)),       i = 0 .. N-1,  sum q_i = mu f_n,

the midpoint discretisation of a uniform density of slip limits on [1 - a, 1 + a] mu f_n / N:
the same stuck stiffness k_t and macro-slip force mu f_n as the Jenkins element, but the
weakest element slips from k_t |g_t - w| = (1 - a (N - 1) / N) mu f_n on (micro-slip), so the
tangential force-displacement curve bends gradually and the pair dissipates
sum_i 4 q_i (x0 - q_i / k_i) per cycle of amplitude x0 (over the elements with k_i x0 > q_i).
With a = 0 the plant keeps the single Jenkins element (N = 1).

Stribeck friction (``_stribeck_mu``, plant.interface.static_excess s > 0): the slider's
coefficient depends on the pair's tangential surface velocity v = dg_t/dt,

    mu(v) = mu_k (1 + s exp(-(v / v_s)^2))       mu_k = plant.interface.mu, v_s = stribeck_velocity_m_s

so a stuck pair breaks away at mu_s f_n = (1 + s) mu_k f_n and slides at mu_k f_n for |v| >> v_s.
The plant step takes v at the start of each substep (lagged by one substep, 48 us at 21 kHz),
so that mu is constant over the substep and the pair law stays piecewise affine in the gaps.

Interface damping (``_interface_dashpot``): Kelvin-Voigt dashpots c = k tau in parallel with the
normal spring (on the change of penetration) and the Jenkins element (faded in over a
penetration depth).

Over a time step the normal spring acts through its discrete gradient (``_normal_impulse``),
so that the work of the contact over the step equals the change of its stored energy even
when the pair opens or closes inside the step (a penalty impact integrated with end-point or
trapezoidal forces gains or loses 1/2 k_n a b per impact; repeated chatter pumps energy).
"""
from __future__ import annotations

import math

import numba


@numba.njit(cache=True, nogil=True, inline="always")
def _jenkins_pair(g_n, g_t, w_old, k_n, k_t, mu):
    """Pair force and its Jacobian. RT-safe.

    Parameters: g_n, g_t [m] gaps; w_old [m] slider position at the start of the step;
    k_n, k_t [N/m]; mu [-].
    Returns (lambda_n [N], lambda_t [N], w_new [m], dlambda_n/dg_n, dlambda_t/dg_n,
    dlambda_t/dg_t [N/m]).
    """
    if g_n >= 0.0:
        return 0.0, 0.0, g_t, 0.0, 0.0, 0.0
    f_n = -k_n * g_n
    f_star = k_t * (g_t - w_old)
    limit = mu * f_n
    if abs(f_star) <= limit:
        return f_n, -f_star, w_old, -k_n, 0.0, -k_t
    sgn = 1.0 if f_star > 0.0 else -1.0
    f_t = limit * sgn
    return f_n, -f_t, g_t - f_t / k_t, -k_n, mu * k_n * sgn, 0.0


@numba.njit(cache=True, nogil=True)
def _iwan_pair(g_n, g_t, w_old, w_new, o, k_n, k_t, mu, kf, qf, prev, tie):
    """Pair force and Jacobian of an Iwan element (N Jenkins elements in parallel). RT-safe.

    Parameters: g_n, g_t [m] gaps at the end of the step; w_old [m] slider positions at its
    start, elements o .. o+N-1 of the pair; w_new [m] written there; k_n, k_t [N/m] the pair's
    stiffnesses; mu [-]; kf, qf (N,) stiffness and slip-limit fractions (k_i = kf_i k_t,
    q_i = qf_i mu f_n); prev: the pair's code in the cached pattern, whose slipping elements
    stay slipping while their trial force is within the relative band `tie` of the limit (where
    stick and slip give the same force: as in plant.newmark._contact_laws for one element).
    Returns (lambda_n [N], lambda_t [N], dlambda_t/dg_n, dlambda_t/dg_t [N/m], code):
    code 0 open, else 1 + sum_i s_i 3^i with s_i = 0 stick, 1 slip +, 2 slip - (for N = 1
    the Jenkins codes 1, 2, 3).
    """
    ne = kf.shape[0]
    if g_n >= 0.0:
        for i in range(ne):
            w_new[o + i] = g_t
        return 0.0, 0.0, 0.0, 0.0, 0
    f_n = -k_n * g_n
    f_t = 0.0
    dtn = 0.0
    dtt = 0.0
    code = 1
    pw = 1
    for i in range(ne):
        k_i = k_t * kf[i]
        q_i = mu * qf[i] * f_n
        f_star = k_i * (g_t - w_old[o + i])
        st = 0
        if abs(f_star) > q_i:
            st = 1 if f_star > 0.0 else 2
        elif prev >= 1:
            sp = ((prev - 1) // pw) % 3
            if (sp == 1 and f_star >= q_i * (1.0 - tie)) or (sp == 2 and -f_star >= q_i * (1.0 - tie)):
                st = sp
        if st == 0:
            w_new[o + i] = w_old[o + i]
            f_t += f_star
            dtt -= k_i
        else:
            sgn = 1.0 if st == 1 else -1.0
            w_new[o + i] = g_t - q_i * sgn / k_i
            f_t += q_i * sgn
            dtn += mu * qf[i] * k_n * sgn
            code += st * pw
        pw *= 3
    return f_n, -f_t, dtn, dtt, code


@numba.njit(cache=True, nogil=True, inline="always")
def _stribeck_mu(mu_k, s, v, v_s):
    """Stribeck friction coefficient mu(v) = mu_k (1 + s exp(-(v / v_s)^2)) [-]. RT-safe.

    mu_k [-] kinetic (sliding) coefficient, s [-] static excess (mu_s = (1 + s) mu_k), v [m/s]
    sliding velocity, v_s [m/s] Stribeck velocity (mu - mu_k falls to 1/e of s mu_k at |v| = v_s).
    """
    x = v / v_s
    return mu_k * (1.0 + s * math.exp(-x * x))


@numba.njit(cache=True, nogil=True, inline="always")
def _normal_impulse(g0, g1, k_n):
    """Mean normal force over a step from g0 to g1: the discrete gradient of V = 1/2 k_n min(0, g)^2.

    Lambda_n = -(V(g1) - V(g0)) / (g1 - g0); equals -1/2 k_n (g0 + g1) when the pair is closed
    at both ends, 0 when open at both. Returns (Lambda_n [N], dLambda_n/dg1 [N/m],
    True if the pair opens or closes within the step). RT-safe.
    """
    c0 = g0 < 0.0
    c1 = g1 < 0.0
    if c0 and c1:
        return -0.5 * k_n * (g0 + g1), -0.5 * k_n, False
    if not c0 and not c1:
        return 0.0, 0.0, False
    dg = g1 - g0  # nonzero: the ends lie on opposite sides of 0
    v0 = 0.5 * k_n * g0 * g0 if c0 else 0.0
    v1 = 0.5 * k_n * g1 * g1 if c1 else 0.0
    dv1 = k_n * g1 if c1 else 0.0
    lam = -(v1 - v0) / dg
    return lam, -(dv1 * dg - (v1 - v0)) / (dg * dg), True


@numba.njit(cache=True, nogil=True, inline="always")
def _interface_dashpot(gn0, gn1, gt0, gt1, cn_h, ct_h, depth):
    """``_interface_dashpot_at`` with the fade-in weight taken at the start gap gn0 (see there). RT-safe."""
    return _interface_dashpot_at(gn0, gn1, gt0, gt1, cn_h, ct_h, depth, gn0)


@numba.njit(cache=True, nogil=True, inline="always")
def _interface_dashpot_at(gn0, gn1, gt0, gt1, cn_h, ct_h, depth, gs):
    """Mean force of the interface dashpots over a step (Kelvin-Voigt, c = k tau). RT-safe.

        normal:      Lambda_dn = -(c_n/h) (min(0, g_n1) - min(0, g_n0))   (penetration change)
        tangential:  Lambda_dt = -(c_t/h) s (g_t1 - g_t0),   s = S(min(1, -min(0, g_n0) / depth)),
                     S(x) = x^2 (3 - 2 x)                                 (smoothstep)

    (here with s = S(min(1, -min(0, gs) / depth)) at a normal gap gs [m] given before the step:
    ``_interface_dashpot`` takes gs = g_n0, the generalized-alpha step the extrapolated end gap)

    Both vanish for a pair open over the whole step and are continuous where it opens or
    closes. The tangential one fades in over the penetration `depth` [m], with its weight s
    taken at the start of the step (lagged): s depending on the end gap g_n1 coupled the
    tangential force of a closing, sliding pair to its normal gap by -(c_t/h) dg_t ds/dg_n1,
    several 1e8 N/m, and Newton stalled on that non-monotone residual (Lyapunov, 20 N at
    205 Hz, tick 17631: |r| 2e-8 m, with a linear ramp and with the smoothstep alike).
    Their work -Lambda_d . dg = (c_n/h) dp dg_n + (c_t/h) s dg_t^2 >= 0 (dp and dg_n share
    their sign). Parameters: gaps at the start and end of the step [m]; cn_h, ct_h = c/h [N/m].
    Returns (Lambda_dn, Lambda_dt [N], dLambda_dn/dg_n1, dLambda_dt/dg_n1 (0), dLambda_dt/dg_t1
    [N/m]). While 0 < s < 1 the last changes from step to step (the plant step updates its cached
    factors for it: plant.newmark._fading_updates).
    """
    p0 = gn0 if gn0 < 0.0 else 0.0
    p1 = gn1 if gn1 < 0.0 else 0.0
    if p0 == 0.0 and p1 == 0.0:
        return 0.0, 0.0, 0.0, 0.0, 0.0
    dp_dg = 1.0 if gn1 < 0.0 else 0.0
    dgt = gt1 - gt0
    x = -(gs if gs < 0.0 else 0.0) / depth
    if x >= 1.0:
        return -cn_h * (p1 - p0), -ct_h * dgt, -cn_h * dp_dg, 0.0, -ct_h
    s = x * x * (3.0 - 2.0 * x)
    return -cn_h * (p1 - p0), -ct_h * s * dgt, -cn_h * dp_dg, 0.0, -ct_h * s
