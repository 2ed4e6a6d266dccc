"""Describing functions of the pairs' tangential law (plant.contact): the first-harmonic
equivalent stiffness of a Jenkins element and of the plant's discrete Iwan element.

Jenkins element (spring k [N/m] in series with a Coulomb slider of slip force q [N]) under the
relative displacement x(t) = a cos(theta), theta = Omega t, in its periodic steady state (the
slider has shaken down: the loop is symmetric, whatever the initial spring force). Stuck for
k a <= q; else, starting at theta = 0 from the end of a positive slip (f = q), it sticks until
f = q - k a (1 - cos theta) reaches -q at theta* and slips at -q up to theta = pi:

    cos(theta*) = 1 - 2 q / (k a),                                  theta* in (0, pi]
    f(theta) ~ Re(k_eq a e^{i theta}),   k_eq = k' + i k''           (first harmonic)
    k'  = (k / pi) (theta* - sin(2 theta*) / 2)                       [N/m]
    k'' = (4 q / (pi a)) (1 - q / (k a))                              [N/m] (>= 0: dissipates)
    k a <= q:  k_eq = k

(Krack & Gross, Harmonic Balance for Nonlinear Vibration Problems, Springer 2019, sec. 2.3
"elastic dry friction"; the same element as NLvib's 'elasticDryFriction'.) k_eq is continuous at
k a = q (theta* = pi: k' = k, k'' = 0) and tends to 4 q / (pi a) i for a >> q / k (pure
Coulomb). Energy dissipated per cycle: pi k'' a^2 = 4 q (a - q / k), the area of the loop.
Derivatives (Newton's Jacobian, for k a > q):

    dk'/da  = -(4 q / (pi a^2)) sin(theta*)
    dk''/da = (4 q / pi) (2 q / (k a^3) - 1 / a^2)

Iwan element (plant.model.iwan_fractions): N Jenkins elements in parallel, k_i = kf_i k_t,
q_i = qf_i mu f_n; its describing function is the sum of theirs (exact for the discrete
element the plant steps, not an approximation of the continuous one).

Design time: one compiled kernel (``_pairs_df``, numba, cache=True) over pairs and elements, behind
the NumPy-facing ``pair_df`` and ``jenkins_df``; the plain NumPy reference is tests/naive.py's.
"""
from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _pairs_df(a, k_t, q, kf, qf, keq, dkeq):
    """(k_eq, dk_eq/da) [N/m, N/m^2] of pairs c at amplitudes a[c] [m] (module docstring) into keq[c],
    dkeq[c]: the sum over the elements i of the Jenkins element k_i = kf[i] k_t[c], q_i = qf[i] q[c] [N];
    stuck (k_i a <= q_i) k_eq = k_i, else the slipping closed form. Arrays (pairs,) and (elements,)."""
    for c in range(a.shape[0]):
        s = a[c]
        e = 0.0 + 0.0j
        d = 0.0 + 0.0j
        for i in range(kf.shape[0]):
            k, qi = kf[i] * k_t[c], qf[i] * q[c]
            if k * s > qi:
                th = math.acos(min(max(1.0 - 2.0 * qi / (k * s), -1.0), 1.0))
                e += complex((k / math.pi) * (th - 0.5 * math.sin(2.0 * th)),
                             (4.0 * qi / (math.pi * s)) * (1.0 - qi / (k * s)))
                d += complex(-(4.0 * qi / (math.pi * s * s)) * math.sin(th),
                             (4.0 * qi / math.pi) * (2.0 * qi / (k * s * s * s) - 1.0 / (s * s)))
            else:
                e += k
        keq[c] = e
        dkeq[c] = d


def pair_df(a, k_t, q, kf: np.ndarray, qf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k_eq, dk_eq/da) [N/m, N/m^2] of pairs' tangential law at amplitudes a [m] (>= 0): the sum of
    the elements' Jenkins describing functions (k_i = kf_i k_t, q_i = qf_i q; one Jenkins element:
    kf = qf = [1]), k_t [N/m] and q = mu f_n [N] (the macro-slip force) per pair; a, k_t, q broadcast
    to one shape (any). Module docstring; the kernel ``_pairs_df``."""
    a, k_t, q = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (a, k_t, q)))
    keq = np.empty(a.shape, complex)
    dkeq = np.empty(a.shape, complex)
    _pairs_df(a.ravel(), k_t.ravel(), q.ravel(), np.asarray(kf, dtype=float), np.asarray(qf, dtype=float),
              keq.reshape(-1), dkeq.reshape(-1))
    return keq, dkeq


def jenkins_df(a, k: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """(k_eq, dk_eq/da): the Jenkins element's complex equivalent stiffness [N/m] and its
    derivative [N/m^2] at the amplitudes a [m] (>= 0, any shape), spring k [N/m], slip force
    q [N] (>= 0; q = 0: a free slider, k_eq = 0 for a > 0). Module docstring."""
    return pair_df(a, k, q, np.ones(1), np.ones(1))


def slider_amplitude(a, k_t, q, kf: np.ndarray, qf: np.ndarray) -> np.ndarray:
    """Slip amplitude [m] of pairs at tangential amplitudes a [m]: half the range of the slider
    motion, max(0, a - q_i / k_i) per element (the Jenkins loop slides by 2 (a - q / k) per half
    cycle), weighted by the elements' stiffness fractions kf (sum 1): 0 while the pair sticks,
    a - q / k_t for one Jenkins element. a, k_t [N/m], q [N] broadcast to one shape (any)."""
    a, k_t, q = (np.asarray(v, dtype=float)[..., None] for v in (a, k_t, q))
    return np.sum(kf * np.maximum(0.0, a - (qf * q) / (kf * k_t)), axis=-1)
