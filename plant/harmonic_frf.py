"""The amplitude-dependent FRF of the plant: single-harmonic balance of its friction joints.

At one excitation force amplitude F [N] (F_exc = Re(F e^{i Omega t}) at the excitation point) the
first harmonic of the periodic response of the preloaded plant, in its modal coordinates q
(Craig-Bampton reduced, mass-normalised, plant.model), with the contact's normal direction held
at the preloaded state (assumptions below):

    (K_s - Omega^2 I + i Omega C) q^ + G_t^T (k_eq(|g^|) - k_t) g^ = b F,   g^ = G_t q^     (1)

K_s, C the stuck model of plant.linear_frf (k_n, k_t and the interface dashpots at the pairs the
screws close; bolts inside the modes), G_t the tangential gap rows of those pairs, g^ their first
harmonics [m], k_eq(a) the pair's describing function (plant.describing: Jenkins element, or the
plant's Iwan element when plant.interface.iwan_spread > 0) with the slip force q_j = mu f_n,j of
the pair's static normal force f_n,j = k_n max(0, -g_n,j) under the screws. Condensed onto the
closed pairs with the stuck model's receptances (one eigen decomposition of its first-order form,
as plant.linear_frf.modal_accelerance: H(Omega) = X diag(1 / (i Omega - lambda)) Y):

    r(g^) = g^ + H_tt (dk(|g^|) g^) - H_tF F = 0,     dk = k_eq - k_t                     (2)
    A_s = -Omega^2 (H_sF F - H_st dk g^) / F        accelerance at sensor s [(m/s^2)/N]

solved per line by Newton on (Re g^, Im g^) with the exact Jacobian of dk (plant.describing) and
a backtracking line search, converged when |r|_inf <= tol |g^|_inf. With every pair stuck
(k_t |g^_j| <= mu f_n,j) dk = 0 and A_s is plant.linear_frf's accelerance exactly.

Lines are solved in the order given, each from the previous line's solution (a step-sine in that
direction); the softening joint makes the response multi-valued near a resonance (the jump of
the step-sine going up or down). ``harmonic_frf`` also solves each line from the stuck and from
the sliding linear solution (tangential springs of the closed pairs removed) and counts the
distinct solutions (``n_solutions`` > 1: the multi-valued region; the reported one is the
continued one). A line none of whose starts converges has converged False and NaN values
(``HarmonicFRF.check`` raises naming them).

Assumptions (what the time-domain plant does that this does not):
- the normal direction is linear about the preload (closed pairs stay closed, open ones open;
  k_n linear), and the slip limit is mu f_n at the static normal force: the plant's mu f_n(t)
  follows the normal force's vibration;
- one harmonic: the higher harmonics of the friction forces are dropped (the response's THD);
- the mean (static) state is the preloaded one (the static tangential forces of the default
  structures are zero, so the shaken-down loops are symmetric);
- Coulomb friction at mu: Stribeck friction (plant.interface.static_excess > 0) is refused.
Validation against the nonlinear step-sine (benchmarks/harmonic_frf.py): docs/plant.md 10.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from plant.aft import _pair_periodic, transforms
from plant.describing import pair_df, slider_amplitude
from plant.linear_frf import stuck_model
from plant.model import PlantModel, contact_forces, preloaded_pairs


class HarmonicSystem(NamedTuple):
    """The design of ``harmonic_frf`` for one plant, preload and sensor set: the stuck model's
    first-order modes and their projections (module docstring, (2)), and the pairs' laws."""
    names: tuple             # sensor names (keys of H)
    closed: np.ndarray       # (p,) bool: pairs the screws close
    k_n: np.ndarray          # (p,) normal stiffness [N/m]
    k_t: np.ndarray          # (p,) tangential stiffness [N/m]
    mu: np.ndarray           # (p,) friction coefficient [-]
    q: np.ndarray            # (p,) slip force mu f_n at the static normal force [N] (0: open)
    kf: np.ndarray           # (N,) element stiffness fractions (plant.model.iwan_fractions)
    qf: np.ndarray           # (N,) element slip-limit fractions
    g0: np.ndarray           # (2p,) static gaps (g_n, g_t per pair) [m]
    w0: np.ndarray           # (p N,) static slider positions [m]
    lam0: np.ndarray         # (2p,) static pair forces [N]
    lam: np.ndarray          # (2n,) eigenvalues of the stuck first-order system [1/s]
    X_g: np.ndarray          # (2p, 2n) pair gaps <- first-order modes
    X_s: np.ndarray          # (m, 2n) sensor displacements <- first-order modes
    Y_b: np.ndarray          # (2n,) first-order modal load of a unit excitation force
    Y_g: np.ndarray          # (2n, 2p) first-order modal load of unit pair forces (lambda_n, lambda_t)


def harmonic_system(model: PlantModel, points: dict[str, str], F_N1: float | None = None) -> HarmonicSystem:
    """Design the harmonic balance of the plant preloaded at F_N1 [N] (None: the configured
    initial value), sensors {name: plant point}. Raises ValueError for an unknown point or for
    Stribeck friction (not described)."""
    cfg = model.cfg
    if cfg.plant.interface.static_excess > 0.0:
        raise ValueError(f"plant.interface.static_excess = {cfg.plant.interface.static_excess}: the harmonic FRF "
                         "describes Coulomb friction only; set it to 0 or use the step-sine "
                         "(rt.experiments.stepsine) for Stribeck friction")
    st = model.structure
    for name, pt in points.items():
        if pt not in st.point_names:
            raise ValueError(f"sensor {name!r} at point {pt!r}: not a plant point; the points are "
                             f"{', '.join(st.point_names)}")
    p = model.params
    lin = stuck_model(model, st.point_names[0], F_N1)
    closed = preloaded_pairs(model, F_N1)
    x0 = model.initial_state(F_N1)
    sl = model.state_slots()
    g0, w0 = x0[sl["g"]].copy(), x0[sl["w"]].copy()
    lam0, _, _ = contact_forces(model, g0, w0)
    n = len(lin.b)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-lin.K, -(lin.C_m + lin.C_c)]])
    lam, V = np.linalg.eig(A)
    rows = p.out_rows[[st.point_names.index(pt) for pt in points.values()]]
    Y = np.linalg.solve(V, np.vstack([np.zeros((n, 1 + p.G.shape[0])), np.column_stack([lin.b, p.G.T])]))
    return HarmonicSystem(names=tuple(points), closed=closed, k_n=p.k_n.copy(), k_t=p.k_t.copy(), mu=p.mu.copy(),
                          q=p.mu * p.k_n * np.maximum(-g0[0::2], 0.0), kf=p.iwan_k.copy(), qf=p.iwan_q.copy(),
                          g0=g0, w0=w0, lam0=lam0, lam=lam, X_g=p.G @ V[:n], X_s=rows @ V[:n], Y_b=Y[:, 0],
                          Y_g=Y[:, 1:])


@dataclass
class HarmonicFRF:
    """``harmonic_frf``'s result at one force amplitude; one row per line, in the order solved."""
    F_amp: float                 # excitation force amplitude [N]
    method: str                  # "df" or "aft" (harmonic_frf)
    freq_hz: np.ndarray          # (lines,) [Hz]
    H: dict                      # {sensor: (lines,) complex first-harmonic accelerance [(m/s^2)/N]}
    g_t: np.ndarray              # (lines, p) complex first harmonic of each pair's tangential gap [m]
    g_n: np.ndarray              # (lines, p) complex first harmonic of each pair's normal gap [m]
    normal_ratio: np.ndarray     # (lines, p) |g^_n| / |g_n0|: > 1 a closed pair would lift off, an open one close
    slip_amp_m: np.ndarray       # (lines, p) slider amplitude [m], half its range (kf-weighted); 0: stuck or open
    open_fraction: np.ndarray    # (lines, p) fraction of the period the pair is open (df: 1 open, 0 closed)
    closed: np.ndarray           # (p,) bool: the pairs the screws close (open pairs carry no force)
    a_slip_m: np.ndarray         # (p,) tangential amplitude where the pair's first element slips [m] (inf: open)
    converged: np.ndarray        # (lines,) bool; False: no start converged, values NaN
    iterations: np.ndarray       # (lines,) Newton iterations of the reported solution
    residual: np.ndarray         # (lines,) |r|_inf / |g^|_inf of the reported solution [-]
    n_solutions: np.ndarray      # (lines,) distinct solutions from the starts tried (> 1: multi-valued)

    @property
    def tangential_amp_m(self) -> np.ndarray:
        """(lines, p) |g^_t| [m], the pairs' relative tangential amplitudes."""
        return np.abs(self.g_t)

    def check(self) -> None:
        """RuntimeError naming the lines where no start converged."""
        bad = self.freq_hz[~self.converged]
        if len(bad):
            raise RuntimeError(f"harmonic balance at {self.F_amp:g} N did not converge at "
                               f"{', '.join(f'{f:g}' for f in bad)} Hz; refine the line spacing (the continuation "
                               "starts from the previous line) or raise max_iter")


def _newton(res, jac, x: np.ndarray, tol: float, max_iter: int):
    """Newton with backtracking on |res|_2 from x; converged when |res|_inf <= tol |x|_inf.
    Returns (x, converged, iterations, relative residual)."""
    r = res(x)
    it = 0
    for it in range(max_iter + 1):
        rel = float(np.max(np.abs(r)) / max(np.max(np.abs(x)), 1e-300))
        if rel <= tol:
            return x, True, it, rel
        if it == max_iter:
            break
        try:
            dx = np.linalg.solve(jac(x), -r)
        except np.linalg.LinAlgError:
            break
        nr, alpha = np.linalg.norm(r), 1.0
        for _ in range(40):
            x_new = x + alpha * dx
            r_new = res(x_new)
            if np.linalg.norm(r_new) < (1.0 - 1e-4 * alpha) * nr:
                break
            alpha *= 0.5
        else:
            break
        x, r = x_new, r_new
    return x, False, it, float(np.max(np.abs(r)) / max(np.max(np.abs(x)), 1e-300))


# --- method "df": describing functions, normal contact linear --------------------------------

def _dk_times(hs: HarmonicSystem, ic: np.ndarray, g: np.ndarray):
    """(dk g, d(dk g)/dRe g, d(dk g)/dIm g) per closed pair ic (module docstring (2))."""
    a = np.abs(g)
    dk = np.empty(len(g), complex)
    dd = np.empty(len(g), complex)
    for c, j in enumerate(ic):
        e, d = pair_df(a[c], hs.k_t[j], hs.q[j], hs.kf, hs.qf)
        dk[c], dd[c] = e - hs.k_t[j], d
    u = dd * g / np.where(a > 0.0, a, 1.0)  # d dk / d a * g / a
    return dk * g, dk + u * g.real, 1j * dk + u * g.imag


def _df_line(hs: HarmonicSystem, ic: np.ndarray, d: np.ndarray, F: float, starts, tol, max_iter):
    """Solutions of (2) on one line from each start (complex g^ of the closed pairs, or None for
    the stuck and sliding starts); returns [(g, converged, iterations, residual)], the pair
    forces' deviation and the modal response of the first."""
    pc = len(ic)
    Htt = (hs.X_g[1::2][ic] * d) @ hs.Y_g[:, 1::2][:, ic]
    u = (hs.X_g[1::2][ic] * d) @ hs.Y_b * F

    def res(x):
        g = x[:pc] + 1j * x[pc:]
        r = g + Htt @ _dk_times(hs, ic, g)[0] - u
        return np.concatenate([r.real, r.imag])

    def jac(x):
        _, dx, dy = _dk_times(hs, ic, x[:pc] + 1j * x[pc:])
        Jx, Jy = np.eye(pc) + Htt * dx[None, :], 1j * np.eye(pc) + Htt * dy[None, :]
        return np.block([[Jx.real, Jy.real], [Jx.imag, Jy.imag]])

    sols = []
    for g0 in starts:
        if isinstance(g0, str):
            g0 = u if g0 == "stuck" else np.linalg.solve(np.eye(pc) - Htt * hs.k_t[ic][None, :], u)
        x, ok, it, rel = _newton(res, jac, np.concatenate([g0.real, g0.imag]), tol, max_iter)
        sols.append((x[:pc] + 1j * x[pc:], ok, it, rel))
    return sols


def _df_response(hs: HarmonicSystem, ic: np.ndarray, d: np.ndarray, F: float, g: np.ndarray) -> np.ndarray:
    """First-order modal response of the first harmonic, from the closed pairs' g^ (method df)."""
    lam_t = np.zeros(hs.X_g.shape[0], complex)
    lam_t[1::2][ic] = -_dk_times(hs, ic, g)[0]   # lambda_t = -f_t
    return d * (hs.Y_b * F + hs.Y_g @ lam_t)


# --- method "aft": the full pair law, harmonics 0..H ------------------------------------------

class _AFT:
    """Residual and Jacobian of the AFT harmonic balance on one line (module docstring): z the
    real coefficients (2H+1, 2p) of the gaps' deviation g - g0 (rows c_0, c_1, s_1, ...)."""

    def __init__(self, hs: HarmonicSystem, w: float, F: float, n_harm: int, n_t: int):
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
        self.M = _block_diag(blocks)
        cl = hs.closed.astype(float)
        self.D0 = np.empty(m)
        self.D0[0::2], self.D0[1::2] = -hs.k_n * cl, -hs.k_t * cl
        self.info = None

    def _pair(self, j: int, zj: np.ndarray):
        """Coefficients (2H+1, 2) of pair j's force deviation for its gap coefficients zj (2H+1, 2);
        (open fraction, slider range weighted by kf)."""
        hs = self.hs
        g = hs.g0[2 * j:2 * j + 2][None, :] + self.E @ zj           # (n_t, 2)
        lam = np.empty_like(g)
        wr = np.empty(len(hs.kf))
        op = _pair_periodic(np.ascontiguousarray(g[:, 0]), np.ascontiguousarray(g[:, 1]),
                            hs.w0[j * len(hs.kf):(j + 1) * len(hs.kf)], hs.k_n[j], hs.k_t[j], hs.mu[j],
                            hs.kf, hs.qf, lam[:, 0], lam[:, 1], wr)
        dl = lam - hs.lam0[2 * j:2 * j + 2][None, :] - (g - hs.g0[2 * j:2 * j + 2][None, :]) * self.D0[2 * j:2 * j + 2]
        return self.P @ dl, (op, 0.5 * float(hs.kf @ wr))

    def forces(self, Z: np.ndarray) -> np.ndarray:
        out = np.empty_like(Z)
        info = []
        for j in range(self.m // 2):
            out[:, 2 * j:2 * j + 2], inf = self._pair(j, Z[:, 2 * j:2 * j + 2])
            info.append(inf)
        self.info = np.array(info)
        return out

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

    def res(self, z: np.ndarray) -> np.ndarray:
        return z - self._mul(self.forces(self._unflat(z))) - self._flat(self.u)

    def jac(self, z: np.ndarray) -> np.ndarray:
        """I - M dL/dz, dL/dz block-diagonal by pair, by forward differences."""
        Z = self._unflat(z)
        nz = len(z)
        DL = np.zeros((nz, nz))
        base = self.forces(Z)
        step = 1e-7 * max(np.max(np.abs(Z)), 1e-15)
        for j in range(self.m // 2):
            cols = [(r, 2 * j + s) for r in range(2 * self.H + 1) for s in range(2)]
            for r, c in cols:
                Zp = Z[:, 2 * j:2 * j + 2].copy()
                Zp[r, c - 2 * j] += step
                dL = (self._pair(j, Zp)[0] - base[:, 2 * j:2 * j + 2]) / step
                full = np.zeros_like(Z)
                full[:, 2 * j:2 * j + 2] = dL
                DL[:, self._index(r, c)] = self._flat(full)
        return np.eye(nz) - self.M @ DL

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
        return self._flat(Z)

    def first_harmonic(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(g^ (2p,) complex first harmonic of the gaps, first-order modal response) at z."""
        Z = self._unflat(z)
        L = self.forces(Z)
        return Z[1] - 1j * Z[2], self.d1 * (self.hs.Y_b * self.F + self.hs.Y_g @ (L[1] - 1j * L[2]))


def _block_diag(blocks):
    n = sum(b.shape[0] for b in blocks)
    M = np.zeros((n, n))
    o = 0
    for b in blocks:
        M[o:o + b.shape[0], o:o + b.shape[0]] = b
        o += b.shape[0]
    return M


# --- the FRF ----------------------------------------------------------------------------------

METHODS = ("df", "aft")


def harmonic_frf(hs: HarmonicSystem, F_amp: float, freq_hz, *, method: str = "df", n_harm: int = 1,
                 n_t: int = 256, tol: float | None = None, max_iter: int = 60, branches: bool = True) -> HarmonicFRF:
    """First-harmonic accelerances at the force amplitude F_amp [N] (> 0) on the lines freq_hz
    [Hz] (> 0), solved in the order given (module docstring).

    method "df": describing functions of the closed pairs' tangential law, normal contact
    linear (fast: ~1-15 ms a line); "aft": the full pair law by AFT with harmonics 0..n_harm on
    n_t samples a period (contact opening and closing, slip limit mu f_n(t), the mean state's
    shift; ~10x the cost), started on each line from the "df" solution as well.
    tol: Newton's relative residual (default 1e-10 df, 1e-8 aft: forward-difference Jacobian);
    branches: also solve from the stuck and the sliding starts and count the distinct solutions
    (False: only the continued start; n_solutions then 1)."""
    f = np.atleast_1d(np.asarray(freq_hz, dtype=float))
    if method not in METHODS:
        raise ValueError(f"method {method!r}: expected one of {', '.join(METHODS)}")
    if not (np.isfinite(F_amp) and F_amp > 0.0):
        raise ValueError(f"F_amp {F_amp!r} N: the harmonic FRF needs a finite force amplitude > 0 N")
    if len(f) == 0 or not np.all(np.isfinite(f) & (f > 0.0)):
        raise ValueError(f"freq_hz {f.tolist()}: give one or more finite frequencies > 0 Hz")
    if n_harm < 1:
        raise ValueError(f"n_harm {n_harm}: must be >= 1")
    tol = (1e-10 if method == "df" else 1e-8) if tol is None else tol
    ic = np.flatnonzero(hs.closed)
    p, lines = len(hs.closed), len(f)
    H = np.full((len(hs.names), lines), np.nan + 0j)
    g1 = np.full((lines, 2 * p), np.nan + 0j)
    conv = np.zeros(lines, bool)
    iters = np.zeros(lines, np.int64)
    resid = np.full(lines, np.nan)
    nsol = np.zeros(lines, np.int64)
    slip = np.full((lines, p), np.nan)
    open_frac = np.full((lines, p), np.nan)
    prev = None
    for i, w in enumerate(2.0 * np.pi * f):
        d = 1.0 / (1j * w - hs.lam)
        df_starts = ([] if prev is None or method == "aft" else [prev]) + (["stuck", "sliding"] if branches else [])
        if method == "df" and not df_starts:
            df_starts = ["stuck"]
        if method == "aft":
            df_starts = df_starts or ["stuck"]
        sols = _df_line(hs, ic, d, F_amp, df_starts, 1e-10, max_iter)
        if method == "aft":
            aft = _AFT(hs, w, F_amp, n_harm, n_t)
            df_g = [np.asarray(_gaps_of(hs, ic, d, F_amp, s[0])) for s in sols if s[1]]
            starts = ([] if prev is None else [prev]) + [aft.start(g) for g in df_g[:1]]
            if branches:
                starts.append(aft.start(None))
            sols = [_newton(aft.res, aft.jac, z0, tol, max_iter) for z0 in starts]
        good = [s for s in sols if s[1]]
        if not good:
            prev = None
            continue
        distinct = []
        for s in good:
            if all(np.max(np.abs(s[0] - t)) > 1e-6 * np.max(np.abs(t)) for t in distinct):
                distinct.append(s[0])
        sol, conv[i], iters[i], resid[i] = good[0]
        nsol[i] = len(distinct)
        prev = sol
        if method == "df":
            modal = _df_response(hs, ic, d, F_amp, sol)
            g1[i] = hs.X_g @ modal
            for j in ic:
                slip[i, j] = slider_amplitude(abs(g1[i, 2 * j + 1]), hs.k_t[j], hs.q[j], hs.kf, hs.qf)
            slip[i, ~hs.closed] = 0.0
            open_frac[i] = (~hs.closed).astype(float)
        else:
            g1[i], modal = aft.first_harmonic(sol)
            open_frac[i], slip[i] = aft.info[:, 0], aft.info[:, 1]
        H[:, i] = -w * w * (hs.X_s @ modal) / F_amp
    a_slip = np.full(p, np.inf)
    for j in ic:
        a_slip[j] = float(np.min(hs.qf * hs.q[j] / (hs.kf * hs.k_t[j])))
    g_n = g1[:, 0::2]
    return HarmonicFRF(F_amp=float(F_amp), method=method, freq_hz=f, H=dict(zip(hs.names, H)), g_t=g1[:, 1::2],
                       g_n=g_n, normal_ratio=np.abs(g_n) / np.maximum(np.abs(hs.g0[0::2]), 1e-300),
                       slip_amp_m=slip, open_fraction=open_frac, closed=hs.closed.copy(), a_slip_m=a_slip,
                       converged=conv, iterations=iters, residual=resid, n_solutions=nsol)


def _gaps_of(hs: HarmonicSystem, ic: np.ndarray, d: np.ndarray, F: float, g: np.ndarray) -> np.ndarray:
    """All pairs' first-harmonic gaps (2p,) of a df solution g (closed pairs' g^_t)."""
    return hs.X_g @ _df_response(hs, ic, d, F, g)
