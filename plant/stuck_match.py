"""Design time: the stepped poles of the stuck, preloaded plant, and period matching on them.

The plant step (plant.newmark) is linear while no pair changes state. About the static state under
the screws (pairs closed by the preload stuck, the others open) one controller step is an affine
map of the state; its linear part ``step_map`` is read off the kernel itself by central
differences (exact for an affine map, to round-off), so it is the map that runs, whatever the
scheme (trapezoid with its quasi-static theta lag, or generalized-alpha with its accelerations and
last contact forces as state). Its eigenvalues z give the stepped poles s = ln z / h.

``stuck_period_matched`` chooses the stepped modes' modal masses and dampings (m_step, c_step;
plant.model.period_matched gives the open-contact values, which match each mode of the bolted
assembly alone) so that the stuck system's stepped poles below omega h = PERIOD_MATCH_MAX equal
the poles of the same system stepped with h / REFERENCE_SPLIT (the step's limit: the reference the
convergence benchmarks use): Gauss-Newton on (ln m, c h), minimum-norm steps from the open-contact
values, so the change is the least that matches. The contact-coupled modes whose frequency comes
from k_n, k_t are built from many open-contact modes and the quasi-static ones, so matching each
open-contact mode alone leaves their periods elongated (docs/plant.md 2.9).
"""
from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from frictionrt.plant.newmark import PlantParams, _plant_step

REFERENCE_SPLIT = 64      # the reference poles: the same step with h / 64 ...
REFERENCE_MAX = 256       # ... and at most 256 substeps per controller step (plant.substeps' bound)
MATCH_TOL = 1e-10         # |Im s h - Im s_ref h| at which the matching stops
MATCH_ITER = 30
GAP_STEP_M = 1e-10        # the central differences move a gap by at most this [m]


def with_step_masses(p: PlantParams, m_d: np.ndarray, c_d: np.ndarray) -> PlantParams:
    """p with the stepped modes' (the first n_dyn) modal masses m_d [-] and dampings c_d [1/s], and
    everything built from them: s2, s2_fine, W, W_fine, out_G (plant.model.build_plant's formulas;
    the fallback substeps keep the m of h)."""
    n_dyn = p.n_dyn
    m_step, c_step = p.m_step.copy(), p.c_step.copy()
    m_step[:n_dyn], c_step[:n_dyn] = m_d, c_d
    om2 = p.omega2[:n_dyn]
    s2, s2_fine = p.s2.copy(), p.s2_fine.copy()
    for arr, hh in ((s2, p.h), (s2_fine, p.h_fine)):
        if p.scheme == 1:
            am, af, beta, gamma = p.ga_am, p.ga_af, p.ga_beta, p.ga_gamma
            arr[:n_dyn] = (1.0 - af) * hh**2 * beta / ((1.0 - am) * m_d + (1.0 - af) * (gamma * hh * c_d
                                                                                         + beta * hh**2 * om2))
        else:
            arr[:n_dyn] = 2.0 / (om2 + 2.0 / hh * c_d + 4.0 / hh**2 * m_d)
    dyn = p.dyn
    return p._replace(m_step=m_step, c_step=c_step, s2=s2, s2_fine=s2_fine,
                      W=np.ascontiguousarray((p.G * s2) @ p.G.T), W_fine=np.ascontiguousarray((p.G * s2_fine) @ p.G.T),
                      out_G=np.ascontiguousarray((p.out_rows * (dyn / m_step)) @ p.G.T))


def step_map(model, params: PlantParams | None = None, F_N1: float | None = None) -> np.ndarray:
    """The linear part of one plant step (params' substeps, default the model's) about the static
    state at F_N1 [N] (default the structure's), on the coordinates q (n), the stepped modes' qd
    (n_dyn) and, for generalized-alpha, their accelerations (n_dyn) and the last contact forces (2p):
    the matrix A with dx_1 = A dx_0. The gaps follow q (g = G q); the sliders are held (stuck)."""
    p = model.params if params is None else params
    x0 = model.initial_state(F_N1)
    sl = model.state_slots()
    F = model.structure.F_N1_initial if F_N1 is None else F_N1
    u = np.array([0.0, F])
    y = np.zeros(len(model.output_labels()))
    n, n_dyn = model.n, p.n_dyn
    idx = list(range(n)) + list(range(n, n + n_dyn))
    if p.scheme == 1:
        idx += list(range(sl["acc"].start, sl["acc"].stop)) + list(range(sl["lam_prev"].start, sl["lam_prev"].stop))
    idx = np.array(idx)
    gslot = sl["g"]
    Gmax = np.maximum(np.max(np.abs(p.G), axis=0), 1e-300)
    A = np.empty((len(idx), len(idx)))
    xn = np.empty_like(x0)
    wk = model.new_work()   # its cached factors belong to p (one contact pattern throughout)
    for k, i in enumerate(idx):
        if i < n:
            d = GAP_STEP_M / Gmax[i]
        elif i < n + n_dyn:
            d = GAP_STEP_M / Gmax[i - n] / p.h
        elif p.scheme == 1 and i < sl["acc"].stop:
            d = GAP_STEP_M / Gmax[i - sl["acc"].start] / p.h**2
        else:
            d = 1e-3   # a contact force [N]
        cols = []
        for sgn in (1.0, -1.0):
            x = x0.copy()
            x[i] += sgn * d
            if i < n:
                x[gslot] += sgn * d * p.G[:, i]
            if _plant_step(np.int64(0), x, u, p, xn, y, wk) < 0:
                raise RuntimeError("the plant step failed about the static state")
            cols.append(xn[idx].copy())
        A[:, k] = (cols[0] - cols[1]) / (2.0 * d)
    return A


def poles(A: np.ndarray, h: float) -> np.ndarray:
    """The oscillatory poles s = ln z / h [1/s] (Im s > 0) of a step map A with step h [s]."""
    z = np.linalg.eigvals(A)
    z = z[(z.imag > 1e-12) & (np.abs(z) > 1e-8)]
    return np.log(z) / h


def _one_substep(p: PlantParams) -> PlantParams:
    return p._replace(substeps=1)


def reference_substeps(substeps: int) -> int:
    """Substeps per controller step of the reference plant: REFERENCE_SPLIT times ``substeps``, at
    most REFERENCE_MAX (plant.substeps' bound)."""
    return min(REFERENCE_MAX, int(substeps) * REFERENCE_SPLIT)


def reference_poles(ref, h: float, omega_h_max: float, F_N1: float | None = None) -> np.ndarray:
    """The stuck system's poles [1/s] with Im s h < omega_h_max of the reference plant ``ref`` (the
    same configuration at ``reference_substeps`` with the open-contact period matching:
    plant.model.stuck_reference; one of its substeps), h the matched plant's substep [s]."""
    s = poles(step_map(ref, _one_substep(ref.params), F_N1), ref.params.h)
    return np.sort_complex(s[s.imag * h < omega_h_max])


def _paired(s: np.ndarray, s_ref: np.ndarray) -> np.ndarray:
    """The poles of s nearest to s_ref, one each (an assignment on |ln(s / s_ref)|)."""
    cost = np.abs(np.log(s[:, None] / s_ref[None, :]))
    r, c = linear_sum_assignment(cost)
    out = np.empty_like(s_ref)
    out[c] = s[r]
    return out


def stuck_period_matched(model, ref, omega_h_max: float = 1.0, F_N1: float | None = None) -> tuple[PlantParams, dict]:
    """The model's params with the stepped modes' modal masses m_step chosen so that the stuck,
    preloaded system's stepped poles with Im s h < omega_h_max have the frequencies Im s of
    ``reference_poles`` of the reference plant ``ref`` (Gauss-Newton in ln m, minimum-norm steps from the open-contact values, the
    Jacobian by differences once and then Broyden's updates). The dampings c_step stay the open-contact
    ones: matching the damping too asks for negative c on some open-contact modes (the trapezoid's
    quasi-static lag damps the stuck modes), which would feed energy into the joint where it opens.
    Returns (params, info): info the reference poles, the open-contact matching's and the result's
    poles [1/s] and the iterations."""
    p0 = model.params
    h, n_dyn = p0.h, p0.n_dyn
    s_ref = reference_poles(ref, h, omega_h_max, F_N1)
    m0, c0 = p0.m_step[:n_dyn].copy(), p0.c_step[:n_dyn].copy()

    def resid(x):
        p = with_step_masses(p0, np.exp(x), c0)
        s = _paired(poles(step_map(model, _one_substep(p), F_N1), h), s_ref)
        return (s.imag - s_ref.imag) * h, s, p

    x = np.log(m0)
    r, s_open, p = resid(x)
    s = s_open
    J = np.empty((len(r), len(x)))
    for j in range(len(x)):
        xp = x.copy()
        xp[j] += 1e-6
        J[:, j] = (resid(xp)[0] - r) / 1e-6
    it = 0
    while it < MATCH_ITER and np.max(np.abs(r)) > MATCH_TOL:
        dx = -np.linalg.lstsq(J, r, rcond=None)[0]
        x = x + dx
        r_new, s, p = resid(x)
        J += np.outer(r_new - r - J @ dx, dx) / (dx @ dx)   # Broyden
        r = r_new
        it += 1
    if np.max(np.abs(r)) > 1e-9:
        raise RuntimeError(f"stuck period matching did not converge: |Im s h - Im s_ref h| = {np.max(np.abs(r)):.2e}")
    return p, {"s_ref": s_ref, "s_open": s_open, "s": s, "iterations": it}
