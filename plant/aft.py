"""Alternating frequency-time (AFT) evaluation of the full pair law over one period (design time).

The harmonic balance's method "aft" (plant.harmonic_frf) needs the Fourier coefficients of the
pair forces for given Fourier coefficients of the pair gaps, with the plant's own law
(plant.contact._iwan_pair: bilinear penalty normal contact, which opens and closes, and the
Jenkins / Iwan tangential element whose slip limit mu f_n(t) follows the normal force):

    g(theta) = c_0 + sum_{h=1}^{H} (c_h cos(h theta) + s_h sin(h theta))    sampled at theta_k = 2 pi k / N_t
    lambda_k = the pair law marched through the samples, two periods from the static slider
               positions (the first shakes the sliders down; a stuck pair keeps its static spring)
    lambda's coefficients = least squares of the second period's samples on the same harmonics

(Cameron & Griffin 1989; NLvib's and tmdsimpy's AFT). The marching is the only per-sample loop,
compiled here (``_pair_periodic``); the transforms are numpy.
"""
from __future__ import annotations

import numba
import numpy as np

from plant.contact import _iwan_pair


@numba.njit(cache=True, nogil=True)
def _pair_periodic(gn, gt, w0, k_n, k_t, mu, kf, qf, lam_n, lam_t, w_range):
    """March one pair's law through two periods of samples gn, gt (N_t,) [m] from its slider
    positions w0 (N,) [m]; fills lam_n, lam_t (N_t,) [N] with the second period's forces and
    w_range (N,) [m] with each slider's (max - min) over it. k_n, k_t [N/m], mu [-] the pair's;
    kf, qf (N,) the element fractions (plant.model.iwan_fractions). Returns the fraction of the
    second period the pair is open (g_n >= 0)."""
    ne = kf.shape[0]
    w = w0.copy()
    w_new = np.empty(ne)
    w_lo = np.empty(ne)
    w_hi = np.empty(ne)
    n_open = 0
    nt = gn.shape[0]
    for c in range(2):
        for k in range(nt):
            ln, lt, _, _, _ = _iwan_pair(gn[k], gt[k], w, w_new, 0, k_n, k_t, mu, kf, qf, -1, 0.0)
            for i in range(ne):
                w[i] = w_new[i]
            if c == 1:
                lam_n[k] = ln
                lam_t[k] = lt
                if gn[k] >= 0.0:
                    n_open += 1
                for i in range(ne):
                    if k == 0 or w[i] < w_lo[i]:
                        w_lo[i] = w[i]
                    if k == 0 or w[i] > w_hi[i]:
                        w_hi[i] = w[i]
    for i in range(ne):
        w_range[i] = w_hi[i] - w_lo[i]
    return n_open / nt


def transforms(n_harm: int, n_t: int) -> tuple[np.ndarray, np.ndarray]:
    """(E, P): samples = E @ coefficients, coefficients = P @ samples for the real coefficients
    [c_0, c_1, s_1, ..., c_H, s_H] (module docstring) at n_t equidistant samples of one period;
    P is E's exact inverse on these harmonics (n_t > 2 H)."""
    if n_t <= 2 * n_harm:
        raise ValueError(f"n_t = {n_t} time samples cannot hold {n_harm} harmonics: give n_t > {2 * n_harm}")
    th = 2.0 * np.pi * np.arange(n_t) / n_t
    cols = [np.ones(n_t)]
    for h in range(1, n_harm + 1):
        cols += [np.cos(h * th), np.sin(h * th)]
    E = np.column_stack(cols)
    P = E.T * (2.0 / n_t)
    P[0] *= 0.5
    return E, P
