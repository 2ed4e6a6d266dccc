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
compiled here (``_pair_periodic``, with the exact derivatives of the marched map); the transforms
are numpy.

The harmonic balance on one line (``AftLine``; plant.harmonic_frf, method "aft"): with Z the real
coefficients of the gaps' deviation g - g0 from the static gaps, dLambda(Z) those of the pair
forces' deviation from the stuck linearisation, H(h Omega) the stuck model's gap receptances,

    R(Z) = Z - H(h Omega) dLambda_h(Z) - [h = 1] H_gF F = 0       per harmonic h = 0 .. H   (A2)

(complex harmonics X_h = c_h - i s_h as real 2 x 2 blocks), solved by ``newton`` with the
Jacobian I - H dLambda/dZ (block-diagonal by pair), the mean tangential gaps held at 0;
``continued`` and ``ramped`` give it starts along the lines and along the force.
"""
from __future__ import annotations

import numba
import numpy as np
import scipy.linalg as sla

from frictionrt.plant.contact import _iwan_pair


@numba.njit(cache=True, nogil=True)
def _pair_periodic(gn, gt, E, w0, k_n, k_t, mu, kf, qf, lam_n, lam_t, dlam, w_range):
    """March one pair's law through two periods of samples gn, gt (N_t,) [m] from its slider
    positions w0 (N,) [m]; fills lam_n, lam_t (N_t,) [N] with the second period's forces,
    dlam (N_t, 2, 2 n_c) with their derivatives [N/m] with respect to the pair's gap coefficients
    (g_n = E @ c_n, g_t = E @ c_t, E (N_t, n_c); columns [c_n, c_t]) and w_range (N,) [m] with each
    slider's (max - min) over the second period. k_n, k_t [N/m], mu [-] the pair's; kf, qf (N,)
    the element fractions (plant.model.iwan_fractions). Returns the fraction of the second
    period the pair is open (g_n >= 0).

    The derivatives are those of the marched map: an element's state (open, stuck, slipping)
    is read from the law's result (stuck: w unchanged), and its slider's derivative dw is carried
    along: open w = g_t (dw = dg_t); stuck dw kept, dlambda_t = -k_i (dg_t - dw); slipping
    w = g_t - q_i s / k_i with q_i = qf_i mu k_n (-g_n), so dw = dg_t + s qf_i mu k_n dg_n / k_i and
    dlambda_t = s qf_i mu k_n dg_n; normal dlambda_n = -k_n dg_n while closed."""
    ne = kf.shape[0]
    nt, nc = E.shape
    w = w0.copy()
    w_new = np.empty(ne)
    w_lo = np.empty(ne)
    w_hi = np.empty(ne)
    dw = np.zeros((ne, 2 * nc))
    dg_t = np.zeros(2 * nc)
    dg_n = np.zeros(2 * nc)
    n_open = 0
    for c in range(2):
        for k in range(nt):
            ln, lt, _, _, _ = _iwan_pair(gn[k], gt[k], w, w_new, 0, k_n, k_t, mu, kf, qf, -1, 0.0)
            for r in range(nc):
                dg_n[r] = E[k, r]
                dg_t[nc + r] = E[k, r]
            closed = gn[k] < 0.0
            for j in range(2 * nc):
                dlam[k, 0, j] = -k_n * dg_n[j] if closed else 0.0
                dlam[k, 1, j] = 0.0
            for i in range(ne):
                k_i = kf[i] * k_t
                if not closed:
                    for j in range(2 * nc):
                        dw[i, j] = dg_t[j]
                elif w_new[i] == w[i]:
                    for j in range(2 * nc):
                        dlam[k, 1, j] -= k_i * (dg_t[j] - dw[i, j])
                else:
                    sg = 1.0 if gt[k] - w_new[i] > 0.0 else -1.0
                    a = sg * qf[i] * mu * k_n
                    for j in range(2 * nc):
                        dw[i, j] = dg_t[j] + a * dg_n[j] / k_i
                        dlam[k, 1, j] += a * dg_n[j]
                w[i] = w_new[i]
            if c == 1:
                lam_n[k] = ln
                lam_t[k] = lt
                if not closed:
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


# --- the harmonic balance on one line (plant.harmonic_frf, method "aft") -------------------------

def _newton(res, jac, x, tol, max_iter, p):
    """Newton with backtracking on |res|_2 from x; converged when |res|_inf <= tol |x|_inf; res(x, p) and
    jac(x, p) with the parameters p passed through. Returns (x, converged, iterations, relative residual).
    One source, run as Python (``newton``) and compiled for compiled res and jac (``newton_compiled``)."""
    r = res(x, p)
    it = 0
    for it in range(max_iter + 1):
        rel = float(np.max(np.abs(r)) / max(np.max(np.abs(x)), 1e-300))
        if rel <= tol:
            return x, True, it, rel
        if it == max_iter:
            break
        J = jac(x, p)
        try:
            dx = np.linalg.solve(J, -r)
        except Exception:   # singular (numba's nopython mode catches no narrower class)
            break
        nr, alpha = np.linalg.norm(r), 1.0
        for _ in range(40):
            x_new = x + alpha * dx
            r_new = res(x_new, p)
            if np.linalg.norm(r_new) < (1.0 - 1e-4 * alpha) * nr:
                break
            alpha *= 0.5
        else:
            break
        x, r = x_new, r_new
    return x, False, it, float(np.max(np.abs(r)) / max(np.max(np.abs(x)), 1e-300))


newton_compiled = numba.njit(cache=True, nogil=True)(_newton)


def newton(res, jac, x: np.ndarray, tol: float, max_iter: int):
    """``_newton`` on Python callables res(x), jac(x)."""
    return _newton(lambda z, _: res(z), lambda z, _: jac(z), x, tol, max_iter, None)


class AftLine:
    """Residual and Jacobian of the AFT harmonic balance on one line Omega = w [rad/s] at the force
    amplitude F [N] (module docstring, (A2)); hs a plant.harmonic_frf.HarmonicSystem. Z: the real
    coefficients (2H+1, 2p) of the gaps' deviation g - g0 (rows c_0, c_1, s_1, ..; columns g_n, g_t
    per pair), flattened harmonic-major; the unknowns are Z without the mean tangential gaps."""

    def __init__(self, hs, w: float, F: float, n_harm: int, n_t: int):
        self.hs, self.H, self.F = hs, n_harm, F
        self.E, self.P = transforms(n_harm, n_t)
        m = hs.X_g.shape[0]
        self.m = m
        blocks, self.u = [], np.zeros((2 * n_harm + 1, m))
        self.d1 = 1.0 / (1j * w - hs.lam)
        for h in range(n_harm + 1):
            Hh = (hs.X_g * (1.0 / (1j * h * w - hs.lam))) @ hs.Y_g
            blocks.append(Hh.real if h == 0 else np.block([[Hh.real, Hh.imag], [-Hh.imag, Hh.real]]))
        u1 = (hs.X_g * self.d1) @ hs.Y_b * F
        self.u[1], self.u[2] = u1.real, -u1.imag
        self.M = sla.block_diag(*blocks)
        cl = hs.closed.astype(float)
        self.D0 = np.empty(m)
        self.D0[0::2], self.D0[1::2] = -hs.k_n * cl, -hs.k_t * cl
        self.info = None
        self.idx = np.array([[self._index(r, c) for c in range(m)] for r in range(2 * n_harm + 1)])
        # the mean tangential gaps stay static (module docstring): not unknowns, their equations dropped
        self.active = np.ones(self.idx.size, bool)
        self.active[self.idx[0, 1::2]] = False

    def _pair(self, j: int, zj: np.ndarray):
        """Pair j's force deviation coefficients (2H+1, 2) for its gap coefficients zj (2H+1, 2),
        their derivative (2H+1, 2, 2 (2H+1)) with respect to zj's columns [c_n, c_t], and
        (open fraction, slider amplitude: half the range, kf-weighted)."""
        hs = self.hs
        sl = slice(2 * j, 2 * j + 2)
        g = hs.g0[sl][None, :] + self.E @ zj                            # (n_t, 2)
        lam = np.empty_like(g)
        dlam = np.empty((len(g), 2, 2 * self.E.shape[1]))
        wr = np.empty(len(hs.kf))
        N = len(hs.kf)
        op = _pair_periodic(np.ascontiguousarray(g[:, 0]), np.ascontiguousarray(g[:, 1]), self.E,
                            hs.w0[j * N:(j + 1) * N], hs.k_n[j], hs.k_t[j], hs.mu[j], hs.kf, hs.qf,
                            lam[:, 0], lam[:, 1], dlam, wr)
        dl = lam - hs.lam0[sl][None, :] - (g - hs.g0[sl][None, :]) * self.D0[sl]
        nc = self.E.shape[1]
        dlam[:, 0, :nc] -= self.D0[2 * j] * self.E
        dlam[:, 1, nc:] -= self.D0[2 * j + 1] * self.E
        return self.P @ dl, np.einsum("rk,kij->rij", self.P, dlam), (op, 0.5 * float(hs.kf @ wr))

    def forces(self, Z: np.ndarray, with_jac: bool = False):
        """Force deviation coefficients (2H+1, 2p) at the gap coefficients Z; with_jac: also
        dL/dz (flattened, block-diagonal by pair)."""
        out = np.empty_like(Z)
        info = []
        nc = 2 * self.H + 1
        DL = np.zeros((Z.size, Z.size)) if with_jac else None
        for j in range(self.m // 2):
            out[:, 2 * j:2 * j + 2], dj, inf = self._pair(j, Z[:, 2 * j:2 * j + 2])
            info.append(inf)
            if with_jac:
                ix = self.idx[:, 2 * j:2 * j + 2].T.ravel()    # [c_n rows, c_t rows] of pair j
                DL[np.ix_(ix, ix)] = dj.transpose(1, 0, 2).reshape(2 * nc, 2 * nc)
        self.info = np.array(info)
        return (out, DL) if with_jac else out

    def _mul(self, L: np.ndarray) -> np.ndarray:
        """The linear map of the force coefficients (2H+1, 2p) to gap coefficients, flattened."""
        vec = np.concatenate([L[0]] + [np.concatenate([L[2 * h - 1], L[2 * h]]) for h in range(1, self.H + 1)])
        return self.M @ vec

    def _flat(self, Z: np.ndarray) -> np.ndarray:
        return np.concatenate([Z[0]] + [np.concatenate([Z[2 * h - 1], Z[2 * h]]) for h in range(1, self.H + 1)])

    def _unflat(self, z: np.ndarray) -> np.ndarray:
        m = self.m
        Z = np.empty((2 * self.H + 1, m))
        Z[0] = z[:m]
        for h in range(1, self.H + 1):
            seg = z[m + 2 * m * (h - 1): m + 2 * m * h]
            Z[2 * h - 1], Z[2 * h] = seg[:m], seg[m:]
        return Z

    def _full(self, za: np.ndarray) -> np.ndarray:
        z = np.zeros(len(self.active))
        z[self.active] = za
        return z

    def res(self, za: np.ndarray) -> np.ndarray:
        """Residual of the active unknowns za (the mean tangential gaps held at 0)."""
        z = self._full(za)
        return (z - self._mul(self.forces(self._unflat(z))) - self._flat(self.u))[self.active]

    def jac(self, z: np.ndarray) -> np.ndarray:
        """I - M dL/dz (dL/dz from the marched law's exact derivatives, plant.aft)."""
        J = np.eye(len(self.active)) - self.M @ self.forces(self._unflat(self._full(z)), with_jac=True)[1]
        return J[np.ix_(self.active, self.active)]

    def _index(self, r: int, c: int) -> int:
        m = self.m
        if r == 0:
            return c
        h = (r + 1) // 2
        return m + 2 * m * (h - 1) + (0 if r % 2 else m) + c

    def start(self, g1: np.ndarray | None) -> np.ndarray:
        """z with the first harmonic g1 (2p complex; None: the stuck linear response) and no mean shift."""
        Z = np.zeros((2 * self.H + 1, self.m))
        if g1 is None:
            Z[1:3] = self.u[1:3]
        else:
            Z[1], Z[2] = g1.real, -g1.imag
        return self._flat(Z)[self.active]

    def first_harmonic(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(g^ (2p,) complex first harmonic of the gaps, first-order modal response) at z."""
        Z = self._unflat(self._full(z))
        L = self.forces(Z)
        return Z[1] - 1j * Z[2], self.d1 * (self.hs.Y_b * self.F + self.hs.Y_g @ (L[1] - 1j * L[2]))


def continued(hs, f0: float, f1: float, z0: np.ndarray, F: float, n_harm: int, n_t: int,
               tol: float, max_iter: int, levels: int = 3):
    """The AFT solution at f1 [Hz] continued from z0, the solution at f0: directly, else over
    2, 4, .. 2^levels equal substeps (each from the last); Newton's (z, converged, it, res)."""
    for n_sub in 2 ** np.arange(levels + 1):
        z, ok = z0, True
        for k in range(1, n_sub + 1):
            a = AftLine(hs, 2.0 * np.pi * (f0 + (f1 - f0) * k / n_sub), F, n_harm, n_t)
            sol = newton(a.res, a.jac, z, tol, max_iter)
            z, ok = sol[0], sol[1]
            if not ok:
                break
        if ok:
            return sol
    return sol


def ramped(hs, f: float, F: float, n_harm: int, n_t: int, tol: float, max_iter: int,
            levels: int = 6):
    """The AFT solution at f [Hz] by continuation in the force: from the stuck response at
    F 2^-levels, each level's solution starting the next, up to F [N] (the start of last resort,
    e.g. past the fold of a branch)."""
    z = None
    for k in range(levels, -1, -1):
        a = AftLine(hs, 2.0 * np.pi * f, F * 2.0 ** -k, n_harm, n_t)
        sol = newton(a.res, a.jac, a.start(None) if z is None else z, tol, max_iter)
        if not sol[1]:
            return sol
        z = sol[0]
    return sol
