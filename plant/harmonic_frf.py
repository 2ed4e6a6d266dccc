"""The amplitude-dependent FRF of the plant: harmonic balance of its friction joints.

At one excitation force amplitude F [N] (F_exc = F cos(Omega t) at the excitation point) the
first harmonic of the periodic response of the preloaded plant, in its modal coordinates q
(Craig-Bampton reduced, mass-normalised, plant.model). The linear part is the stuck model of
plant.linear_frf, (K_s - Omega^2 I + i Omega C) q^ = b F + G^T lambda^ (k_n, k_t and the
interface dashpots at the pairs the screws close; bolts inside the modes), and the pair forces
enter as their deviation from that linearisation about the static state under the screws,

    dlambda = lambda(g) - lambda(g0) - D0 (g - g0),   D0 = diag(-k_n, -k_t) at the closed pairs,

condensed onto the pair gaps g = G q by the stuck model's receptances (one eigen decomposition
of its first-order form, as plant.linear_frf.modal_accelerance: H(h Omega) = X diag(1 / (i h Omega
- lambda)) Y). Two methods:

"df", describing functions, normal contact linear: the closed pairs' tangential forces by the
Jenkins / Iwan element's describing function k_eq(a) (plant.describing; Krack & Gross 2019) with
the slip force mu f_n,j at the pair's static normal force f_n,j = k_n max(0, -g_n,j):

    r(g^_t) = g^_t + H_tt ((k_eq(|g^_t|) - k_t) g^_t) - H_tF F = 0                         (D)

Newton on (Re g^_t, Im g^_t) with the exact Jacobian of k_eq, compiled (plant.aft.newton_compiled): 0.06-0.12
ms a line with one start (docs/plant.md 10).

"aft", alternating frequency-time with harmonics 0..H of every pair's normal and tangential gap
(plant.aft): the plant's own pair law (penalty contact that opens and closes, slip limit
mu f_n(t) following the normal force, Jenkins or Iwan) marched through a period of samples:

    Z = H(h Omega) dLambda_h(Z) + [h = 1] H_gF F,   h = 0 .. H                               (A)

Newton with the marched law's exact derivatives. The mean tangential gaps are held at their
static values (a slipping pair's mean position is indeterminate in a periodic solution: the
plant keeps it from its history). 0.1-1.7 s a line where pairs slip and contact opens and closes.

With every pair stuck and no pair opening or closing dlambda = 0 and both give plant.linear_frf's
accelerance exactly. Which to use: the result's normal_ratio (|g^_n| over the static gap or
penetration) > 1 says that contact opens or closes somewhere in the cycle and "df" is off
(measured: docs/plant.md 10); "aft" with H = 3 follows the step-sine within a few percent where
it converges.

Lines are solved in the order given, each continued from the previous line's solution (a
step-sine in that direction: the joint makes the response multi-valued near a resonance, the
jump of a step-sine); "aft" subdivides the step to the line when the direct continuation fails
and, if every start fails, ramps the force up from 1/64 of F on that line. ``branches`` also solves
each line from the stuck and the df (or sliding) starts and counts the distinct solutions
(``n_solutions`` > 1: multi-valued; the reported one is the continued one); without it "aft" tries
the df start only where the continuation fails (the cheap solve of a fit). A line where no start
converges has converged False and NaN values (``HarmonicFRF.check`` raises naming them): never
a silent value.

Assumptions (what the time-domain plant does that this does not): one harmonic (df) or H (aft) of
a response that has more (the step-sine's THD); the mean tangential state is the static one;
Coulomb friction at mu: Stribeck friction (plant.interface.static_excess > 0) is refused; the
interface dashpots stay linear at their static weights; df: the normal direction is linear
(closed pairs stay closed, open ones open) and the slip limit is mu f_n at the static normal
force. Validation against the nonlinear step-sine (benchmarks/harmonic_frf.py): docs/plant.md 10.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np
from threadpoolctl import threadpool_limits

from frictionrt.plant.aft import AftLine, continued, newton, newton_compiled, ramped
from frictionrt.plant.describing import _pairs_df, slider_amplitude
from frictionrt.plant.linear_frf import stuck_model
from frictionrt.plant.model import PlantModel, contact_forces, preloaded_pairs


class HarmonicSystem(NamedTuple):
    """The design of ``harmonic_accelerances`` for one plant, preload and sensor set: the stuck model's
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


U_REL = "u_rel"   # a sensor "point" that is the damper's relative displacement u_rel (the plant's output row)


def harmonic_system(model: PlantModel, points: dict[str, str], F_N1: float | None = None) -> HarmonicSystem:
    """Design the harmonic balance of the plant preloaded at F_N1 [N] (None: the configured
    initial value), sensors {name: plant point, or ``U_REL``: the damper's relative displacement,
    whose "accelerance" is -Omega^2 u_rel^ / F}. Raises ValueError for an unknown point or for
    Stribeck friction (not described)."""
    cfg = model.cfg
    if cfg.plant.interface.static_excess > 0.0:
        raise ValueError(f"plant.interface.static_excess = {cfg.plant.interface.static_excess}: the harmonic FRF "
                         "describes Coulomb friction only; set it to 0 or use the step-sine "
                         "(rt.experiments.stepsine) for Stribeck friction")
    st = model.structure
    for name, pt in points.items():
        if pt not in st.point_names and pt != U_REL:
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
    rows = p.out_rows[[len(st.point_names) if pt == U_REL else st.point_names.index(pt) for pt in points.values()]]
    Y = np.linalg.solve(V, np.vstack([np.zeros((n, 1 + p.G.shape[0])), np.column_stack([lin.b, p.G.T])]))
    return HarmonicSystem(names=tuple(points), closed=closed, k_n=p.k_n.copy(), k_t=p.k_t.copy(), mu=p.mu.copy(),
                          q=p.mu * p.k_n * np.maximum(-g0[0::2], 0.0), kf=p.iwan_k.copy(), qf=p.iwan_q.copy(),
                          g0=g0, w0=w0, lam0=lam0, lam=lam, X_g=p.G @ V[:n], X_s=rows @ V[:n], Y_b=Y[:, 0],
                          Y_g=Y[:, 1:])


@dataclass
class HarmonicFRF:
    """``harmonic_accelerances``'s result at one force amplitude; one row per line, in the order solved."""
    F_amp: float                 # excitation force amplitude [N]
    method: str                  # "df" or "aft" (harmonic_frf)
    freq_hz: np.ndarray          # (lines,) [Hz]
    H: dict                      # {sensor: (lines,) complex first-harmonic accelerance [(m/s^2)/N]}
    g_t: np.ndarray              # (lines, p) complex first harmonic of each pair's tangential gap [m]
    g_n: np.ndarray              # (lines, p) complex first harmonic of each pair's normal gap [m]
    normal_ratio: np.ndarray     # (lines, p) |g^_n| / |g_n0|: > 1 a closed pair would lift off, an open one close
    slip_amp_m: np.ndarray       # (lines, p) slider amplitude [m], half its range (kf-weighted; aft: with its free
    #                              motion while the pair is open); 0: stuck or open all period
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


# --- method "df": describing functions, normal contact linear --------------------------------

@numba.njit(cache=True, nogil=True, error_model="numpy")
def _dk_times(g, k_t, q, kf, qf):
    """(dk g, d(dk g)/dRe g, d(dk g)/dIm g) of the closed pairs' complex gaps g^_t (pc,), dk = k_eq(|g|) - k_t
    (module docstring (2); k_t [N/m], q [N] per closed pair, the elements' fractions kf, qf)."""
    a = np.abs(g)
    keq = np.empty(len(g), np.complex128)
    dd = np.empty(len(g), np.complex128)
    _pairs_df(a, k_t, q, kf, qf, keq, dd)
    dk = keq - k_t
    u = dd * g / np.where(a > 0.0, a, 1.0)  # d dk / d a * g / a
    return dk * g, dk + u * g.real, 1j * dk + u * g.imag


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _df_residual(x, p):
    """r of (D) at x = (Re g^_t, Im g^_t): g^_t + H_tt (dk g^_t) - H_tF F, as (Re r, Im r); p = (H_tt, H_tF F,
    k_t, q, kf, qf) of the line (``df_matrices``) and the closed pairs' law."""
    Htt, u, k_t, q, kf, qf = p
    pc = len(u)
    g = x[:pc] + 1j * x[pc:]
    r = g + Htt @ _dk_times(g, k_t, q, kf, qf)[0] - u
    return np.concatenate((r.real, r.imag))


@numba.njit(cache=True, nogil=True, error_model="numpy")
def _df_jacobian(x, p):
    """dr/dx of ``_df_residual`` (2 pc, 2 pc): [[Re Jx, Re Jy], [Im Jx, Im Jy]], Jx = I + H_tt diag(d(dk g)/dRe g),
    Jy = i I + H_tt diag(d(dk g)/dIm g); p as there."""
    Htt, _, k_t, q, kf, qf = p
    pc = Htt.shape[0]
    _, dx, dy = _dk_times(x[:pc] + 1j * x[pc:], k_t, q, kf, qf)
    J = np.empty((2 * pc, 2 * pc))
    for i in range(pc):
        for j in range(pc):
            jx, jy = Htt[i, j] * dx[j], Htt[i, j] * dy[j]
            if i == j:
                jx, jy = jx + 1.0, jy + 1j
            J[i, j], J[i, pc + j], J[pc + i, j], J[pc + i, pc + j] = jx.real, jy.real, jx.imag, jy.imag
    return J


def df_matrices(hs: HarmonicSystem, ic: np.ndarray, d: np.ndarray, F: float) -> tuple[np.ndarray, np.ndarray]:
    """(H_tt, H_tF F) of (D) on the lines whose first-order modal receptances are d = 1 / (i Omega - lambda)
    ((2n,) one line, (lines, 2n) many): the closed pairs' tangential gap receptances to their forces
    [m/N] and their gaps under the excitation force F [N] [m]."""
    Xd = hs.X_g[1::2][ic] * d[..., None, :]
    return Xd @ hs.Y_g[:, 1::2][:, ic], Xd @ hs.Y_b * F


def _df_line(hs: HarmonicSystem, ic: np.ndarray, Htt: np.ndarray, u: np.ndarray, starts, tol, max_iter):
    """Solutions of (2) on one line (its ``df_matrices``) from each start (complex g^ of the closed pairs, or
    "stuck" and "sliding"), by plant.aft's compiled Newton; returns [(g, converged, iterations, residual)]."""
    pc = len(ic)
    p = (Htt, u, hs.k_t[ic], hs.q[ic], hs.kf, hs.qf)
    sols = []
    for g0 in starts:
        if isinstance(g0, str):
            g0 = u if g0 == "stuck" else np.linalg.solve(np.eye(pc) - Htt * hs.k_t[ic][None, :], u)
        x, ok, it, rel = newton_compiled(_df_residual, _df_jacobian, np.concatenate([g0.real, g0.imag]), tol,
                                         max_iter, p)
        sols.append((x[:pc] + 1j * x[pc:], ok, it, rel))
    return sols


def _df_response(hs: HarmonicSystem, ic: np.ndarray, d: np.ndarray, F: float, g: np.ndarray) -> np.ndarray:
    """First-order modal response of the first harmonic, from the closed pairs' g^ (method df): one line
    (d (2n,), g (pc,)) or many (d (lines, 2n), g (lines, pc))."""
    k = np.broadcast_to(hs.k_t[ic], g.shape)
    q = np.broadcast_to(hs.q[ic], g.shape)
    lam_t = np.zeros(g.shape[:-1] + (hs.X_g.shape[0],), complex)
    lam_t[..., 2 * ic + 1] = -_dk_times(np.ascontiguousarray(g).ravel(), k.ravel(), q.ravel(), hs.kf,
                                        hs.qf)[0].reshape(g.shape)   # lambda_t = -f_t
    return d * (hs.Y_b * F + lam_t @ hs.Y_g.T)


# --- the FRF ----------------------------------------------------------------------------------

METHODS = ("df", "aft")


def harmonic_accelerances(hs: HarmonicSystem, F_amp: float, freq_hz, *, method: str = "aft", n_harm: int = 3,
                          n_t: int = 256, tol: float | None = None, max_iter: int = 60,
                          branches: bool = True) -> HarmonicFRF:
    """First-harmonic accelerances at the sensors of ``hs`` at the force amplitude F_amp [N] (> 0)
    on the lines freq_hz [Hz] (> 0), solved in the order given (module docstring); returns a
    ``HarmonicFRF`` (H per sensor, the pairs' gaps, slip and contact per line, convergence).

    method "df": describing functions of the closed pairs' tangential law, normal contact
    linear (measured 0.06-0.12 ms a line with one start, docs/plant.md 10); "aft": the full pair law by AFT with
    harmonics 0..n_harm on n_t samples a period (contact opening and closing, slip limit
    mu f_n(t), the mean normal gaps' shift; 0.1-1.7 s a line), each line also started from the
    "df" solution. tol: Newton's relative residual (default 1e-10 df; 1e-8 aft, whose marched law
    is piecewise linear in the samples). branches: also solve from the stuck and the sliding
    (df) or stuck (aft) starts and count the distinct solutions (False: fewer starts, about half
    the cost, aft's df start only where the continuation from the previous line fails; n_solutions
    then counts only those)."""
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
    with threadpool_limits(1):   # small solves: two BLAS threads on a loaded 2-core machine made each 50x slower
        return _frf(hs, F_amp, f, method, n_harm, n_t, tol, max_iter, branches)


def _frf(hs: HarmonicSystem, F_amp: float, f: np.ndarray, method: str, n_harm: int, n_t: int, tol: float,
         max_iter: int, branches: bool) -> HarmonicFRF:
    """``harmonic_accelerances`` after its checks."""
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
    w_all = 2.0 * np.pi * f
    D = 1.0 / (1j * w_all[:, None] - hs.lam[None, :])
    Htt, u = df_matrices(hs, ic, D, F_amp)
    g_df = np.full((lines, len(ic)), np.nan + 0j)
    prev = None
    for i, w in enumerate(w_all):
        df_starts = ([] if prev is None or method == "aft" else [prev]) + (["stuck", "sliding"] if branches else [])
        df_starts = df_starts or ["stuck"]
        if method == "df":
            sols = _df_line(hs, ic, Htt[i], u[i], df_starts, 1e-10, max_iter)
        else:
            aft = AftLine(hs, w, F_amp, n_harm, n_t)
            sols = [] if prev is None else [continued(hs, f[i - 1], f[i], prev, F_amp, n_harm, n_t, tol, max_iter)]
            if branches or not sols[:1] or not sols[0][1]:   # without branches: the df start only if needed
                df_g = [np.asarray(_gaps_of(hs, ic, D[i], F_amp, s[0]))
                        for s in _df_line(hs, ic, Htt[i], u[i], df_starts, 1e-10, max_iter) if s[1]]
                starts = [aft.start(g) for g in df_g[:1]] + ([aft.start(None)] if branches else [])
                sols += [newton(aft.res, aft.jac, z0, tol, max_iter) for z0 in starts]
            if not any(sl[1] for sl in sols):
                sols.append(ramped(hs, f[i], F_amp, n_harm, n_t, tol, max_iter))
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
            g_df[i] = sol
        else:
            g1[i], modal = aft.first_harmonic(sol)
            open_frac[i], slip[i] = aft.info[:, 0], np.where(aft.info[:, 0] < 1.0, aft.info[:, 1], 0.0)
            H[:, i] = -w * w * (hs.X_s @ modal) / F_amp
    if method == "df":    # every converged line at once
        ok = np.flatnonzero(conv)
        modal = _df_response(hs, ic, D[ok], F_amp, g_df[ok])
        g1[ok] = modal @ hs.X_g.T
        H[:, ok] = (-(w_all[ok] ** 2)[:, None] * (modal @ hs.X_s.T) / F_amp).T
        slip[ok] = 0.0
        slip[np.ix_(ok, ic)] = slider_amplitude(np.abs(g1[np.ix_(ok, 2 * ic + 1)]), hs.k_t[ic], hs.q[ic], hs.kf, hs.qf)
        open_frac[ok] = (~hs.closed).astype(float)
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
