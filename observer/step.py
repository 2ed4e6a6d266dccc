"""Run time: the nonlinear observer's step at 21 kHz (SPEC section 5, paper Eq. 5-9).

    z' = A z + B_T f_r(v_rel_hat, F_N) + L (y_meas - C_meas z),   u_rel_hat = C_u z + D_u f_r
    f_r(v, F_N) = mu F_N (2/pi) arctan(alpha v)                    regularised Coulomb [N]

discretised (``frictionrt.observer.kalman``) as, per tick k with the a-priori state z_k|k-1 (state slots):

    e      = y_k - C_meas z_k|k-1                         innovation [m/s]
    z_k|k  = z_k|k-1 + M e                                measurement update (filter form)
    outputs: v_rel_hat = C_v z_k|k,  f_r,k = f_r(v_rel_hat, F_N,k),
             u_rel_hat = C_u z_k|k + D_u f_r,k
    v_next solves  v = C_v A_d z_k|k + beta f_r(v, F_N,k),  beta = C_v B_dT < 0
    z_k+1|k = A_d z_k|k + B_dT f_r(v_next, F_N,k)         time update, friction implicit in v

The implicit friction (the force held over the tick is the one at the end-of-tick velocity) keeps
the step stable however stiff mu F_N alpha is: g(v) = v - beta f_r(v) - v* is strictly
increasing (g' >= 1), its root lies between 0 and v* (friction only brakes), and a Newton
iteration safeguarded by that bracket finds it to round-off in a few iterations.

F_N is the measured adaptive-screw force (the piezo force cell): the friction that acts is the
one of the actual force, which lags the law's command through the force tracking (up to 1 ms
on a 560 N step); the force cell measures it at > 20 kHz.

Inputs u = (y_meas [m/s] tip velocity from the sensor chain, F_N [N]).
Outputs ``OBSERVER_OUTPUTS`` = (u_rel_hat [m], v_rel_hat [m/s], innovation [m/s], f_r_hat [N]).
State: z_k|k-1 (2N).
"""
from __future__ import annotations

import math

import numba

from frictionrt.observer.atan import _atan

OBSERVER_OUTPUTS = (("u_rel_hat", "m"), ("v_rel_hat", "m/s"), ("innovation", "m/s"), ("f_r_hat", "N"))
NEWTON_MAX = 60  # the bound: the tick's stated worst case (docs/observer.md gives the measured counts)
TWO_OVER_PI = 2.0 / math.pi


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _friction(v, F_N, mu, alpha):
    """f_r = mu F_N (2/pi) arctan(alpha v) [N] and its slope df_r/dv [N s/m]; arctan of observer.atan
    (the same bits on every machine). RT-safe."""
    c = mu * F_N * TWO_OVER_PI
    av = alpha * v
    return c * _atan(av), c * alpha / (1.0 + av * av)


@numba.njit(cache=True, nogil=True, _nrt=False)
def _implicit_v_iter(v_star, beta, F_N, mu, alpha):
    """Root of g(v) = v - beta f_r(v) - v_star (beta < 0), between 0 and v_star, and the
    iterations it took: (v [m/s], n). RT-safe.

    Newton on g (g' = 1 - beta df_r/dv >= 1) safeguarded by the bracket [lo, hi] that every
    residual's sign narrows. It stops on an exact root (g == 0) and when a Newton step is at most
    tol = 1e-15 (|v_star| + 1e-12) m/s, both before the bracket test (a converged step rounds onto
    an end of the bracket, which the strict test would reject); a step that leaves the bracket is
    replaced by its midpoint. At most ``NEWTON_MAX`` iterations: the stated worst case.
    """
    lo = min(0.0, v_star)
    hi = max(0.0, v_star)
    v = v_star
    tol = 1e-15 * (abs(v_star) + 1e-12)
    for it in range(NEWTON_MAX):
        f, df = _friction(v, F_N, mu, alpha)
        g = v - beta * f - v_star
        if g == 0.0:
            return v, it + 1  # an exact root
        if g > 0.0:
            hi = v
        else:
            lo = v
        v_new = v - g / (1.0 - beta * df)
        if abs(v_new - v) <= tol:
            return v_new, it + 1  # converged
        if not (lo < v_new < hi):
            v_new = 0.5 * (lo + hi)  # Newton left the bracket: bisect
        v = v_new
    return v, NEWTON_MAX


@numba.njit(cache=True, nogil=True, _nrt=False)
def _implicit_v(v_star, beta, F_N, mu, alpha):
    """Root of g(v) = v - beta f_r(v) - v_star (beta < 0), between 0 and v_star
    (``_implicit_v_iter`` without the count) [m/s]. RT-safe."""
    return _implicit_v_iter(v_star, beta, F_N, mu, alpha)[0]


@numba.njit(cache=True, nogil=True, _nrt=False)
def _observer_step(k, x, u, p, x_next, y):
    """One tick of the observer (module docstring). RT-safe, allocation-free.

    k int64 tick (unused: time-invariant); x (2N,) z_k|k-1; u (2,) = (y_meas [m/s], F_N [N]);
    p ObserverParams; x_next (2N,) z_k+1|k (written; must not alias x); y (4,) outputs at t_k.
    z_k|k = x + M e is formed on the fly, never stored.
    """
    A_d, B_dT, M, C_meas, C_u, C_v, CvA = p.A_d, p.B_dT, p.M, p.C_meas, p.C_u, p.C_v, p.CvA
    n = x.shape[0]
    y_meas = u[0]
    F_N = u[1]
    e = y_meas
    for i in range(n):
        e -= C_meas[i] * x[i]
    v_hat = 0.0
    u_lin = 0.0
    v_star = 0.0
    for i in range(n):
        zi = x[i] + M[i] * e
        v_hat += C_v[i] * zi
        u_lin += C_u[i] * zi
        v_star += CvA[i] * zi
    f_k, _ = _friction(v_hat, F_N, p.mu, p.alpha)
    y[0] = u_lin + p.D_u * f_k
    y[1] = v_hat
    y[2] = e
    y[3] = f_k
    # time update with the friction at the end-of-tick velocity
    v_next = _implicit_v(v_star, p.beta, F_N, p.mu, p.alpha)
    f_next, _ = _friction(v_next, F_N, p.mu, p.alpha)
    L = p.L
    for i in range(n):  # A_d z_k|k = A_d x + L e (L = A_d M, the predictor gain)
        acc = B_dT[i] * f_next + L[i] * e
        for j in range(n):
            acc += A_d[i, j] * x[j]
        x_next[i] = acc
