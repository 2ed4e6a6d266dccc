"""The superelement Newton's kink step (plant.se_plant._first_kink): the first branch change of the
end-point law along a Newton step, against a bisection of the law's own branch (plant.contact3d)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


class _P(NamedTuple):      # the fields of SEParams that _first_kink reads
    nt: int
    k_n: np.ndarray
    k_t: np.ndarray
    mu: np.ndarray


class _WK(NamedTuple):     # the fields of SEWork that _first_kink reads
    g_old: np.ndarray
    dg: np.ndarray


def _branch(g, w, p, i):
    """The branch of point i's end-point law at gaps g (0 open, 1 stick, 2 slip)."""
    from frictionrt.plant.contact3d import _coulomb_disc
    d = 1 + p.nt
    lam, w_new, D = np.zeros(d), np.zeros(len(w)), np.zeros(d * d)
    return _coulomb_disc(g, i * d, p.nt, w, i * p.nt, p.k_n[i], p.k_t[i], p.mu[i], lam, 0, w_new, D, 0)


def _bisect_first_change(g_old, dg, w, p):
    """The smallest alpha in (0, 1) where any point's branch differs from its branch at alpha = 0+,
    by a scan of 500 steps and 50 bisections; 2.0 if none."""
    n_pts = len(p.k_n)
    start = [_branch(g_old - 1e-12 * dg, w, p, i) for i in range(n_pts)]
    grid = np.linspace(0.0, 1.0, 501)[1:]
    for lo, hi in zip(np.r_[1e-12, grid[:-1]], grid):
        if any(_branch(g_old - hi * dg, w, p, i) != start[i] for i in range(n_pts)):
            for _ in range(50):
                mid = 0.5 * (lo + hi)
                if any(_branch(g_old - mid * dg, w, p, i) != start[i] for i in range(n_pts)):
                    hi = mid
                else:
                    lo = mid
            return hi
    return 2.0


def test_first_kink_is_the_laws_first_branch_change():
    """Random steps of three points (2-D friction): the closed-form first kink (a sign change of g_n,
    or a root of the quadratic |f*|^2 - (mu f_n)^2) is where the law itself first changes branch,
    to 1e-9 of the step; in 30 draws every kind occurs (open <-> closed, stick -> slip, slip -> stick)
    and a step without a change gives 2.0."""
    from frictionrt.plant.se_plant import _first_kink
    rng = np.random.default_rng(7)
    k_n = np.array([2e7, 3e7, 1e7])
    p = _P(2, k_n, 0.5 * k_n, np.array([0.3, 0.5, 0.4]))
    seen = set()
    for _ in range(30):
        g_old = np.zeros(9)
        g_old[0::3] = rng.uniform(-1e-6, 0.3e-6, 3)
        g_old[1::3] = rng.uniform(-1e-6, 1e-6, 3)
        g_old[2::3] = rng.uniform(-1e-6, 1e-6, 3)
        w = rng.uniform(-1e-6, 1e-6, 6)
        dg = rng.normal(0.0, 1e-6, 9)
        wk = _WK(g_old, dg)
        got = _first_kink(p, wk, w)
        want = _bisect_first_change(g_old, dg, w, p)
        assert abs(got - want) <= 1e-9 or (got == 2.0 and want == 2.0), (got, want)
        if got < 1.0:
            i_b = [_branch(g_old - (got - 1e-7) * dg, w, p, i) for i in range(3)]
            i_a = [_branch(g_old - (got + 1e-7) * dg, w, p, i) for i in range(3)]
            seen |= {(a, b) for a, b in zip(i_b, i_a) if a != b}
        else:
            seen.add("none")
    assert {(0, 1), (1, 2), (2, 1), "none"} <= seen or {(0, 2), (1, 2), (2, 1), "none"} <= seen, seen
