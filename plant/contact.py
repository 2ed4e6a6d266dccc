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
"""
from __future__ import annotations

import numba


@numba.njit(cache=True, nogil=True)
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
