"""Where a bolt's force reaches the interface: the pressure cone of VDI 2230 (docs/plant.md 1.4).

A bolt clamps the beams through its head (and, at the adaptive screw, the piezo stack under it):
the head's bearing pressure spreads through the upper beam in a cone of half-angle phi and reaches
the interface over a disc of radius

    R_c = d_w / 2 + t_upper tan(phi)                                           [m]

d_w the head's bearing diameter, t_upper the upper beam's thickness. VDI 2230-1 (2015), Eq. (5.1/24)
for through-bolted joints gives the cone angle from the joint's proportions,

    tan(phi) = 0.362 + 0.032 ln(beta_L / 2) + 0.153 ln(y),   beta_L = l_K / d_w,  y = D_A / d_w,

l_K the clamp length (both beams), D_A the clamped parts' outer width (here the beams' width).
For an M8 hex head (d_w = 13 mm) through the benchmark's 8 + 8 mm steel beams, 40 mm wide:
tan(phi) = 0.519, phi = 27.4 deg, R_c = 6.5 + 8 x 0.519 = 10.65 mm.

In the 2-D model the cone's pressure is taken as falling linearly from the axis to zero at R_c,
p(x) ~ max(0, 1 - |x - x_s| / R_c) along the interface, and cut where the interface ends (a screw
near the damper's end: its pressure is carried by the interface that is there). The contact points
take it by the hat-function integrals of plant/tributary.py, w_i ~ int p N_i dx, normalised to sum 1,
so that a finer pitch samples the same pressure distribution (the earlier point sampling put 50/50
on the pairs at +-10 mm at a 20 mm pitch and 89 % on the pair under the screw at 10 mm). The bolt's
spring acts on the same weighted separation sum_i w_i g_n,i (the virtual work of the shared force).
A force applied at the pairs goes straight through the interface; one applied at a node between
two pairs bends both beams over the span and lifts the interface elsewhere (15 um in the middle of
the damper at a 20 mm pitch).
"""
from __future__ import annotations

import math

import numpy as np

from frictionrt.plant.tributary import hat_integrals


def vdi_cone_tan(d_w: float, l_K: float, D_A: float) -> float:
    """tan(phi) of the pressure cone (VDI 2230-1, through-bolted joint): d_w head bearing
    diameter, l_K clamp length, D_A outer width of the clamped parts [m]."""
    return 0.362 + 0.032 * math.log(l_K / d_w / 2.0) + 0.153 * math.log(D_A / d_w)


def cone_radius(d_w: float, t_upper: float, tan_phi: float) -> float:
    """Radius [m] of the cone's footprint at the interface under a head of bearing diameter d_w
    through an upper part of thickness t_upper [m]."""
    return 0.5 * d_w + t_upper * tan_phi


def pressure_weights(x_pairs: np.ndarray, x_s: float, R_c: float) -> np.ndarray:
    """Share of a bolt's force taken by each contact point (x_pairs [m]) of a cone of radius R_c [m]
    around x_s: w_i ~ int max(0, 1 - |x - x_s| / R_c) N_i(x) dx over the interface, sum 1 (module
    docstring). ValueError naming the screw position and the remedy if the cone misses the
    interface (e.g. an interface of a single point)."""
    w = hat_integrals(x_pairs, lambda x: np.maximum(0.0, 1.0 - np.abs(x - x_s) / R_c), (x_s - R_c, x_s, x_s + R_c))
    if not np.any(w > 0.0):
        raise ValueError(f"the pressure cone (radius {R_c * 1e3:.3g} mm) of the screw at x = {x_s:g} m does not reach "
                         "the interface's contact points: move the screw onto the interface or give the interface a "
                         "length (plant.interface.x_start_m < x_end_m)")
    return w / w.sum()


def cone_footprint(x_pairs: np.ndarray, x_s: float, R_c: float) -> np.ndarray:
    """Length [m] of the cone's footprint |x - x_s| <= R_c on the interface that each contact point
    stands for (hat-function integrals of its indicator; sum = the footprint's length)."""
    return hat_integrals(x_pairs, lambda x: (np.abs(x - x_s) <= R_c).astype(float), (x_s - R_c, x_s + R_c))
