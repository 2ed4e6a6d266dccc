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

In the 2-D model the bolt acts on the contact pairs inside that disc: its force is shared by them
with weights w_i proportional to the cone's pressure, taken as falling linearly from the axis to
zero at R_c (w_i ~ 1 - |x_i - x_s| / R_c, normalised to sum 1), and its spring acts on the same
weighted separation sum_i w_i g_n,i (the virtual work of the shared force). A force applied at the
pairs goes straight through the interface; one applied at a node between two pairs bends both
beams over the 20 mm span and lifts the interface elsewhere (15 um in the middle of the damper).
"""
from __future__ import annotations

import math

import numpy as np


def vdi_cone_tan(d_w: float, l_K: float, D_A: float) -> float:
    """tan(phi) of the pressure cone (VDI 2230-1, through-bolted joint): d_w head bearing
    diameter, l_K clamp length, D_A outer width of the clamped parts [m]."""
    return 0.362 + 0.032 * math.log(l_K / d_w / 2.0) + 0.153 * math.log(D_A / d_w)


def cone_radius(d_w: float, t_upper: float, tan_phi: float) -> float:
    """Radius [m] of the cone's footprint at the interface under a head of bearing diameter d_w
    through an upper part of thickness t_upper [m]."""
    return 0.5 * d_w + t_upper * tan_phi


def pressure_weights(x_pairs: np.ndarray, x_s: float, R_c: float) -> np.ndarray:
    """Share of a bolt's force taken by each pair (x_pairs [m]) inside its cone of radius R_c [m]
    around x_s: w_i ~ 1 - |x_i - x_s| / R_c, sum 1. ValueError naming the screw position and the
    remedy if no pair lies inside the cone."""
    w = np.maximum(0.0, 1.0 - np.abs(np.asarray(x_pairs, float) - x_s) / R_c)
    if not np.any(w > 0.0):
        raise ValueError(f"no contact pair within the pressure cone (radius {R_c * 1e3:.3g} mm) of the screw at "
                         f"x = {x_s:g} m: move the screw, refine plant.interface.pitch_m or enlarge the "
                         "screw's head_diameter_m")
    return w / w.sum()
