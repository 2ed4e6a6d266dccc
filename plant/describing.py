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

Design time (numpy, vectorised over amplitudes).
"""
from __future__ import annotations

import numpy as np


def jenkins_df(a, k: float, q: float) -> tuple[np.ndarray, np.ndarray]:
    """(k_eq, dk_eq/da): the Jenkins element's complex equivalent stiffness [N/m] and its
    derivative [N/m^2] at the amplitudes a [m] (>= 0, any shape), spring k [N/m], slip force
    q [N] (>= 0; q = 0: a free slider, k_eq = 0 for a > 0). Module docstring."""
    a = np.asarray(a, dtype=float)
    keq = np.full(a.shape, complex(k))
    dkeq = np.zeros(a.shape, dtype=complex)
    slip = k * a > q
    if not np.any(slip):
        return keq, dkeq
    s = a[slip]
    th = np.arccos(np.clip(1.0 - 2.0 * q / (k * s), -1.0, 1.0))
    keq[slip] = (k / np.pi) * (th - 0.5 * np.sin(2.0 * th)) + 1j * (4.0 * q / (np.pi * s)) * (1.0 - q / (k * s))
    dkeq[slip] = (-(4.0 * q / (np.pi * s * s)) * np.sin(th)
                  + 1j * (4.0 * q / np.pi) * (2.0 * q / (k * s ** 3) - 1.0 / s ** 2))
    return keq, dkeq


def pair_df(a, k_t: float, q: float, kf: np.ndarray, qf: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k_eq, dk_eq/da) [N/m, N/m^2] of one pair's tangential law at amplitudes a [m]: the sum of
    the elements' ``jenkins_df`` (k_i = kf_i k_t, q_i = qf_i q; one Jenkins element: kf = qf = [1]),
    q = mu f_n [N] the pair's macro-slip force."""
    a = np.asarray(a, dtype=float)
    keq = np.zeros(a.shape, dtype=complex)
    dkeq = np.zeros(a.shape, dtype=complex)
    for k_i, q_i in zip(np.asarray(kf) * k_t, np.asarray(qf) * q):
        e, d = jenkins_df(a, k_i, q_i)
        keq += e
        dkeq += d
    return keq, dkeq


def slider_amplitude(a, k_t: float, q: float, kf: np.ndarray, qf: np.ndarray) -> np.ndarray:
    """Slip amplitude [m] of a pair at tangential amplitude a [m]: half the range of the slider
    motion, max(0, a - q_i / k_i) per element (the Jenkins loop slides by 2 (a - q / k) per half
    cycle), weighted by the elements' stiffness fractions kf (sum 1): 0 while the pair sticks,
    a - q / k_t for one Jenkins element."""
    a = np.asarray(a, dtype=float)
    out = np.zeros(a.shape)
    for f_k, k_i, q_i in zip(np.asarray(kf), np.asarray(kf) * k_t, np.asarray(qf) * q):
        out += f_k * np.maximum(0.0, a - q_i / k_i)
    return out
