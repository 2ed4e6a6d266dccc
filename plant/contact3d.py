"""Contact law of one point of a 3-D interface (SPEC section 2; docs/superelement.md, "Contact").

Local gaps g = (g_n, g_t1, g_t2): g_n > 0 open, (g_t1, g_t2) the slip in the contact plane along
two orthonormal directions (one direction for a 2-D joint: nt = 1). The point's force on the
structure lambda = (lambda_n, lambda_t) acts along the gap directions (generalised force R^T lambda).

    f_n   = k_n max(0, -g_n)                           bilinear penalty [N]
    f*    = k_t (g_t - w_old)                          trial tangential force (vector) [N]
    stick |f*| <= mu f_n:  f_t = f*,  w = w_old
    slip  |f*| >  mu f_n:  f_t = mu f_n f*/|f*|,  w = g_t - f_t / k_t        (radial return)
    open  f_n = f_t = 0,  w = g_t
    lambda_n = f_n,  lambda_t = -f_t

The radial return is the closest-point projection of f* onto the disc |f| <= mu f_n in the metric
of the isotropic spring k_t I, so it is the exact solution of the implicit (backward Euler) slip
rule w - w_old = gamma f_t / |f_t|, gamma >= 0, for the circular Coulomb cone: no iteration, and
the slip increment is parallel to the force (normality). With nt = 1 it is the Jenkins element
of plant.contact (|f*| = abs, f*/|f*| = sign).

Tangent (d lambda / d g, the Newton Jacobian), with e = f*/|f*|, r = mu f_n / |f*| in slip:

    stick   d lambda_t / d g_t = -k_t I
    slip    d lambda_t / d g_t = -k_t r (I - e e^T),   d lambda_t / d g_n = mu k_n e

Interface dashpots: c_n = k_n tau on the change of penetration, c_t = k_t tau on the tangential
slip rate while the point is closed, as the 2-D joint's (plant.contact._interface_dashpot).
"""
from __future__ import annotations

import math

import numba

FASTMATH = {"reassoc", "contract"}


@numba.njit(cache=True, nogil=True, _nrt=False, fastmath=FASTMATH)
def _coulomb_disc(g, o, nt, w_old, ow, k_n, k_t, mu, lam, ol, w_new, D, od):
    """Force, slider and tangent of one contact point with a circular Coulomb limit. RT-safe.

    Parameters
    ----------
    g : gaps; the point's (g_n, g_t1[, g_t2]) at g[o : o + 1 + nt] [m]
    nt : tangential directions (1 or 2)
    w_old : slider positions, the point's at w_old[ow : ow + nt] [m]
    k_n, k_t : [N/m] the point's stiffnesses (per unit area x area); mu [-]
    lam : written: the point's (lambda_n, lambda_t) at lam[ol : ol + 1 + nt] [N]
    w_new : written: the sliders at w_new[ow : ow + nt] [m]
    D : written: d lambda / d g (1 + nt)^2 row-major at D[od : od + (1 + nt)^2] [N/m]

    Returns 0 open, 1 stick, 2 slip.
    """
    d = 1 + nt
    for i in range(d * d):
        D[od + i] = 0.0
    g_n = g[o]
    if g_n >= 0.0:
        lam[ol] = 0.0
        for a in range(nt):
            lam[ol + 1 + a] = 0.0
            w_new[ow + a] = g[o + 1 + a]
        return 0
    f_n = -k_n * g_n
    lam[ol] = f_n
    D[od] = -k_n
    s2 = 0.0
    for a in range(nt):
        fa = k_t * (g[o + 1 + a] - w_old[ow + a])
        lam[ol + 1 + a] = fa        # f* for now
        s2 += fa * fa
    limit = mu * f_n
    if s2 <= limit * limit:
        for a in range(nt):
            lam[ol + 1 + a] = -lam[ol + 1 + a]
            w_new[ow + a] = w_old[ow + a]
            D[od + (1 + a) * d + 1 + a] = -k_t
        return 1
    norm = math.sqrt(s2)
    r = limit / norm
    e1 = lam[ol + 1] / norm
    e2 = lam[ol + 2] / norm if nt == 2 else 0.0
    for a in range(nt):
        e_a = e1 if a == 0 else e2
        f_a = limit * e_a
        w_new[ow + a] = g[o + 1 + a] - f_a / k_t
        lam[ol + 1 + a] = -f_a
        D[od + (1 + a) * d] = mu * k_n * e_a
        for b in range(nt):
            e_b = e1 if b == 0 else e2
            D[od + (1 + a) * d + 1 + b] = -k_t * r * ((1.0 if a == b else 0.0) - e_a * e_b)
    return 2
