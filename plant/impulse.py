"""Simulated impulse-hammer test: accelerance FRF and modal damping (SPEC section 6, Fig. 5).

The hammer is a half-sine force pulse at the excitation point; the response is the
acceleration at the FRF point. The FRF is H = A(f) / F(f) with an exponential window on the
response (impact-testing practice against leakage of lightly damped modes); the window's
known decay rate 1/tau_w is removed from each identified pole. Each mode is fitted as one
mode plus residual terms in its own band around the mode of the linearised preloaded model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionrt.plant.model import PlantModel, preloaded_pairs, stuck_frequencies_hz
from frictionrt.plant.simulate import run

MODES = (2, 3, 4, 5)  # bending modes identified (mode 1 is not excited in the experiments)


@dataclass(frozen=True)
class ImpulseResult:
    """FRF and identified modal parameters of one impulse test."""
    fn1_n: float
    freq: np.ndarray            # [Hz]
    frf: np.ndarray             # accelerance [(m/s^2)/N], complex
    modes: tuple[int, ...]
    freq_hz: np.ndarray         # identified natural frequencies of `modes` [Hz]
    damping_ratio: np.ndarray   # identified damping ratios of `modes` [-] (window corrected)
    t: np.ndarray               # [s]
    force: np.ndarray           # hammer force [N]
    accel: np.ndarray           # response [m/s^2]

    def to_json(self) -> dict:
        return {"fn1_n": self.fn1_n, "modes": list(self.modes),
                "freq_hz": [round(float(f), 3) for f in self.freq_hz],
                "damping_ratio": [float(f"{z:.6g}") for z in self.damping_ratio]}


def hammer_force(n_steps: int, dt: float, peak: float, duration: float) -> np.ndarray:
    """Half-sine pulse F(t) = peak sin(pi t / duration) for t < duration [N]."""
    t = np.arange(n_steps) * dt
    return np.where(t < duration, peak * np.sin(np.pi * np.minimum(t, duration) / duration), 0.0)


def accelerance_frf(force: np.ndarray, accel: np.ndarray, dt: float, tau_w: float):
    """H(f) = FFT(accel * exp(-t/tau_w)) / FFT(force); returns (freq [Hz], H)."""
    t = np.arange(len(force)) * dt
    A = np.fft.rfft(accel * np.exp(-t / tau_w))
    F = np.fft.rfft(force)
    return np.fft.rfftfreq(len(force), dt), A / F


def _sdof_residual(params, omega, H):
    """Residual of the best linear (A, B, C) for a mode (omega_n, zeta), variable projection."""
    wn, zeta = params
    basis = np.stack([-omega**2 / (wn**2 - omega**2 + 2j * zeta * wn * omega),
                      np.ones_like(omega), omega**2], axis=1)
    coef, *_ = np.linalg.lstsq(basis, H, rcond=None)
    r = basis @ coef - H
    return np.concatenate([r.real, r.imag])


def fit_mode(freq: np.ndarray, frf: np.ndarray, f_lo: float, f_hi: float) -> tuple[float, float]:
    """One mode in [f_lo, f_hi]: accelerance -omega^2 A / (omega_n^2 - omega^2 + 2 i zeta omega_n omega)
    + B + C omega^2 (B, C: residuals of the modes below and above), fitted by least squares.

    A, B, C (complex) are solved linearly for each (omega_n, zeta), which scipy's
    least_squares then optimises. Returns (f_n [Hz], zeta [-]); NaN if the optimum sits on
    the band edge (no mode in the band) or the band holds fewer than 4 lines (a sparse stepped sine:
    3 complex coefficients and 2 parameters need more).
    """
    from scipy.optimize import least_squares
    sel = (freq >= f_lo) & (freq <= f_hi)
    if sel.sum() < 4:
        return np.nan, np.nan
    omega, H = 2 * np.pi * freq[sel], frf[sel]
    w_pk = omega[np.argmax(np.abs(H))]
    lo, hi = 2 * np.pi * f_lo, 2 * np.pi * f_hi
    best = None
    for z0 in (0.002, 0.02, 0.1):
        sol = least_squares(_sdof_residual, x0=[w_pk, z0], args=(omega, H),
                            bounds=([lo, 1e-5], [hi, 0.5]), x_scale=[w_pk * 0.01, z0])
        if best is None or sol.cost < best.cost:
            best = sol
    wn, zeta = best.x
    if not (lo * 1.001 < wn < hi * 0.999) or zeta >= 0.499:
        return np.nan, np.nan
    return wn / (2 * np.pi), zeta


def identify(freq: np.ndarray, frf: np.ndarray, approx_hz: np.ndarray, tau_w: float,
             half_band: float = 0.08) -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [Hz] and damping ratios [-] of the modes near `approx_hz`.

    Each mode is fitted in its own band approx (1 -+ half_band) by ``fit_mode``. The
    exponential window's decay rate 1/tau_w is removed from each pole (exact for a linear
    mode). Why not sdypy-EMA: its LSCF identifies the linear (stuck, small-amplitude) response
    to within 0.01 % of damping, but on friction-distorted peaks it returns no stable pole or
    one far off (see docs/plant.md, "Modal identification"); tests cross-check the two on the
    linear case.
    """
    fn = np.full(len(approx_hz), np.nan)
    zeta = np.full(len(approx_hz), np.nan)
    for k, f0 in enumerate(approx_hz):
        f_w, xi_w = fit_mode(freq, frf, f0 * (1 - half_band), f0 * (1 + half_band))
        if np.isnan(f_w):
            continue
        # pole of the windowed response: -sigma_w + i omega_d; the window adds 1/tau_w to sigma
        sigma = xi_w * 2 * np.pi * f_w - 1.0 / tau_w
        omega_d = 2 * np.pi * f_w * np.sqrt(max(0.0, 1.0 - xi_w**2))
        omega_n = np.hypot(sigma, omega_d)
        fn[k] = omega_n / (2 * np.pi)
        zeta[k] = sigma / omega_n
    return fn, zeta


def impulse_test(model: PlantModel, fn1: float) -> ImpulseResult:
    """Run the hammer test at constant F_N1 = fn1 [N] and identify modes 2-5."""
    cfg = model.cfg
    imp = cfg.impulse
    dt = cfg.dt_s
    n = int(round(imp.record_s / dt))
    force = hammer_force(n, dt, imp.peak_N, imp.duration_s)
    Y, _, _ = run(model, force, fn1)
    accel = Y[:, model.output_index()[f"a_{cfg.plant.frf_point}"]]
    tau_w = imp.record_s / 4.0
    freq, H = accelerance_frf(force, accel, dt, tau_w)
    # approximate frequencies: the linearised preloaded model (closed pairs stuck)
    f_lin = stuck_frequencies_hz(model, preloaded_pairs(model, fn1))
    approx = np.array([f_lin[m - 1] for m in MODES])
    fn, zeta = identify(freq, H, approx, tau_w)
    return ImpulseResult(float(fn1), freq, H, MODES, fn, zeta, np.arange(n) * dt, force, accel)


def plot_frf(res: ImpulseResult, path: str | None = None, f_max: float | None = None):
    """Log-magnitude accelerance over frequency up to ``f_max`` [Hz] (None: the FRF's last line)
    with the identified modes marked (cf. Fig. 5); a matplotlib Figure, also written to ``path``
    (PNG) if given."""
    from matplotlib.figure import Figure
    f_max = float(res.freq[-1]) if f_max is None else f_max
    sel = (res.freq > 1.0) & (res.freq <= f_max)
    fig = Figure(figsize=(8, 4.5))
    ax = fig.subplots()
    ax.semilogy(res.freq[sel], np.abs(res.frf[sel]), lw=0.8, color="C0", label="simulated")
    for m, f, z in zip(res.modes, res.freq_hz, res.damping_ratio):
        ax.axvline(f, color="0.6", lw=0.6, ls="--")
        ax.annotate(f"mode {m}\n{f:.1f} Hz\nzeta {100 * z:.2f} %", (f, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(3, -4), textcoords="offset points", va="top", fontsize=8)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("accelerance |a/F| [(m/s^2)/N]")
    ax.set_title(f"Impulse FRF, F_N1 = {res.fn1_n:g} N (cf. Becker & Gaul Fig. 5)")
    ax.set_xlim(0, f_max)
    ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=120)
    return fig
