"""Energy bookkeeping of the plant from its state (design time and tests).

Balance (SPEC check 4): W_exc + W_screw = (T + V) - (T + V)_0 + E_fric + E_damp, with
T = 1/2 sum m_step qd^2 (m_step = 1 unless period-matched: plant.newmark), V = 1/2 q^T Omega^2 q + contact spring energy
(1/2 k_n g_n^2 for g_n < 0, 1/2 k_t (g_t - w)^2 on closed pairs; an Iwan element's
sum_i 1/2 k_i (g_t - w_i)^2).
"""
from __future__ import annotations

import numpy as np

from frictionrt.plant.model import PlantModel


def mechanical_energy(model: PlantModel, x: np.ndarray) -> tuple[float, float]:
    """(kinetic T [J], potential V [J]) of state x, contact springs included."""
    sl = model.state_slots()
    q, qd, w, g = x[sl["q"]], x[sl["qd"]], x[sl["w"]], x[sl["g"]]
    p = model.params
    T = 0.5 * float(p.m_step @ qd**2)
    g_n, g_t = g[0::2], g[1::2]
    closed = g_n < 0.0
    V = 0.5 * float(np.sum(model.omega**2 * q**2))
    V += 0.5 * float(np.sum(p.k_n[closed] * g_n[closed] ** 2))
    w = w.reshape(model.n_pairs, model.n_sliders)
    k_i = np.outer(p.k_t, p.iwan_k)
    V += 0.5 * float(np.sum(k_i[closed] * (g_t[closed, None] - w[closed]) ** 2))
    return T, V


def balance(model: PlantModel, x0: np.ndarray, x: np.ndarray) -> dict[str, float]:
    """Terms of the energy balance between states x0 and x [J]; 'residual' = input - stored - lost."""
    sl = model.state_slots()
    T0, V0 = mechanical_energy(model, x0)
    T, V = mechanical_energy(model, x)
    terms = {k: float(x[sl[k]][0] - x0[sl[k]][0]) for k in ("W_exc", "W_screw", "E_fric", "E_damp")}
    terms["dT"] = T - T0
    terms["dV"] = V - V0
    terms["residual"] = (terms["W_exc"] + terms["W_screw"]
                         - terms["dT"] - terms["dV"] - terms["E_fric"] - terms["E_damp"])
    return terms
