"""What each contact point carries of a quantity spread along the interface (SPEC 2: the
interface's parameters are per unit area).

The contact points x_0 < x_1 < ... < x_m (pitch h) sample a continuous interface of width b. A
quantity with a line density p(x) along the interface (a stiffness per unit length k'' b, a bolt's
pressure) is given to the points by integrating it against their hat functions, the linear
interpolation N_i that is 1 at x_i and 0 at the neighbours,

    P_i = int_{x_0}^{x_m} p(x) N_i(x) dx,        sum_i P_i = int_{x_0}^{x_m} p(x) dx,

so refining the pitch samples the same physical distribution instead of redistributing it. With
p = 1 this is the tributary length l_i (h inside, h/2 at both ends), and a pair's stiffness is
k_n'' b l_i. The integrand is piecewise polynomial of degree <= 2 between the points and the
profile's own break points, so two-point Gauss-Legendre per piece is exact.
"""
from __future__ import annotations

import numpy as np

_GAUSS_X = np.array([-1.0, 1.0]) / np.sqrt(3.0)   # two-point Gauss-Legendre on [-1, 1], weights 1


def hat_integrals(x_pts: np.ndarray, profile, breaks=()) -> np.ndarray:
    """P_i = int p(x) N_i(x) dx over [x_pts[0], x_pts[-1]] (module docstring) [unit of p x m].

    x_pts: increasing contact point positions [m]; profile: vectorised p(x), linear between
    ``breaks`` and the points (it may jump at a break: only interior points are evaluated).
    A single point (an interface of length 0) carries nothing: zeros.
    """
    x_pts = np.asarray(x_pts, float)
    n = len(x_pts)
    out = np.zeros(n)
    if n < 2:
        return out
    lo, hi = x_pts[0], x_pts[-1]
    cuts = np.unique(np.concatenate([x_pts, np.clip(np.asarray(breaks, float), lo, hi)]))
    a, b = cuts[:-1], cuts[1:]
    mid, half = 0.5 * (a + b), 0.5 * (b - a)
    for g in _GAUSS_X:
        x = mid + half * g
        p = np.asarray(profile(x), float) * half
        j = np.clip(np.searchsorted(x_pts, x, side="right") - 1, 0, n - 2)   # the pitch holding x
        t = (x - x_pts[j]) / (x_pts[j + 1] - x_pts[j])
        np.add.at(out, j, p * (1.0 - t))
        np.add.at(out, j + 1, p * t)
    return out


def tributary_lengths(x_pts: np.ndarray) -> np.ndarray:
    """Length of interface each contact point stands for [m]: the pitch, half of it at both ends."""
    return hat_integrals(x_pts, np.ones_like)
