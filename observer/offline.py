"""Offline reference estimator: filterpy's unscented Kalman filter and its RTS smoother
on the observer's own discrete model, run on a logged run.

The real-time observer (``frictionrt.observer.step``) is a constant-gain filter: its gain M is the steady
state of the linear Kalman filter at v_rel = 0, F_N = 0 (``frictionrt.observer.kalman``). This module runs the
same nonlinear model without that restriction, as a reference of what an unconstrained estimator
achieves on the same data:

* the UKF (``filterpy.kalman.UnscentedKalmanFilter``, ``MerweScaledSigmaPoints``, 2n + 1 = 29
  sigma points) propagates the covariance through the friction nonlinearity and carries a
  time-varying gain: causal, the best filter of this model short of a particle filter;
* the Rauch-Tung-Striebel smoother of that UKF (``UnscentedKalmanFilter.rts_smoother``) also
  uses the future measurements: non-causal, the best this model can do on the data if the
  model and its noise assumptions were right.

The gap between the real-time observer and the UKF is what the constant gain costs; the gap to
the smoother is what the data still hold for a causal estimator of this model; the smoother's own
error is the model's (7 modes, modal damping, regularised friction, white noise in place of the
unknown excitation). Where the model is wrong the smoother, trusting it in both directions of
time, can be worse than the filter (``benchmarks/observer_offline.py``: the Lyapunov law's
switching rings the structure at 600..1500 Hz). With the default noise design the friction term
hardly matters to any of the three: the friction input's process noise (observer.fric_noise_N,
100 N rms per tick) exceeds the friction force mu F_N itself, and the posterior spread of v_rel
(sqrt(C_v P C_v^T) = 1.5 mm/s) is small against the regularisation width 1/alpha, so the UKF is
close to the linear Kalman filter and close to the real-time observer.

Model (per tick k, dt = 1/21000 s; the same discrete model and the same friction treatment as
``frictionrt.observer.step``; state z = [q; q'], 2N = 14 modal states):

    z_k+1 = f(z_k, F_N,k) + w_k,       w_k ~ N(0, Q_d)
    f(z, F_N) = A_d z + B_dT f_r(v_next, F_N),
                v_next solves v = C_v A_d z + beta f_r(v, F_N),   beta = C_v B_dT < 0
    f_r(v, F_N) = mu F_N (2/pi) arctan(alpha v)              regularised Coulomb [N]
    y_k = C_meas z_k + e_k,            e_k ~ N(0, R)          tip velocity [m/s]
    Q_d = G diag(sigma_F^2, sigma_T^2) G^T,  G = [B_dF, B_dT]  (the Kalman design's noise)

Outputs at tick k from the (filtered or smoothed) state z_k:

    v_rel_hat = C_v z_k [m/s],   u_rel_hat = C_u z_k + D_u f_r(C_v z_k, F_N,k) [m]

The timing is the real-time observer's: the measurement y_k and force F_N,k of tick k enter
z_k|k, and the friction of the transition k -> k+1 uses F_N,k (held over the tick).

Slow (plain Python around filterpy: 0.4..1 ms per tick for the filter and about as much for the
smoother on a loaded 2-core machine): meant for runs of 0.3..0.5 s. Not RT-safe, not used by the
loop.
"""
from __future__ import annotations

import time
from typing import NamedTuple

import numba
import numpy as np
import scipy.linalg as sla
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from tqdm import tqdm

from frictionrt.observer.accuracy import TAIL, at_estimate_instant, band_limited_truth, nrmse
from frictionrt.observer.kalman import ObserverDesign, design_observer, zoh
from frictionrt.observer.step import _friction, _implicit_v

PROGRESS_MIN_STEPS = 2000  # show a progress bar (on a terminal) from this many ticks on
# Merwe's scaled sigma points: alpha = 1, kappa = 0 put the 2n points at +-sqrt(n) sigma with a
# zero-weight centre point (no negative weights: the covariance stays positive semi-definite
# through the unscented transform); beta = 2 is the Gaussian optimum. The widest spread lets the
# sigma points reach into the friction's saturation (|alpha v| > 1); a small alpha would make the
# UKF a finite-difference EKF. (Measured: alpha = 1, 0.1 and 1e-3 give the same NRMSE to 1e-3
# with the default design, whose v_rel spread is well inside 1/alpha.)
SIGMA_ALPHA = 1.0
SIGMA_BETA = 2.0
SIGMA_KAPPA = 0.0


class OfflineEstimate(NamedTuple):
    """States and outputs of one UKF (and RTS) pass over a record of n ticks."""
    z_filt: np.ndarray           # (n, 2N) filtered states z_k|k
    P_filt: np.ndarray           # (n, 2N, 2N) their covariances
    z_smooth: np.ndarray | None  # (n, 2N) smoothed states z_k|n (None without the smoother)
    P_smooth: np.ndarray | None  # (n, 2N, 2N)
    us_per_step_filter: float    # wall time of the filter per tick [us]
    us_per_step_smoother: float  # of the smoother per tick [us] (nan without it)


def process_noise(design: ObserverDesign) -> np.ndarray:
    """Q_d = G diag(Q) G^T, G = [B_dF, B_dT] (ZOH of the excitation and friction inputs) [modal^2].

    The covariance per tick of the process noise that ``frictionrt.observer.kalman`` designs the gain for
    (``control.dlqe(A_d, G, C, Q, R)``): rank 2."""
    m = design.model
    _, B_d = zoh(m.A, np.column_stack([m.B_F, m.B_T]), design.dt)
    return B_d @ design.Q @ B_d.T


def _psd_sqrt(P: np.ndarray) -> np.ndarray:
    """Upper-triangular square root U (U^T U = P) of a covariance, as filterpy's sigma points
    expect; P is symmetrised first and, if round-off has left it indefinite, its negative
    eigenvalues are clipped (U then comes from the eigen-decomposition, same U^T U)."""
    P = 0.5 * (P + P.T)
    try:
        return sla.cholesky(P, lower=False, check_finite=False)
    except sla.LinAlgError:
        w, V = np.linalg.eigh(P)
        return np.sqrt(np.clip(w, 0.0, None))[:, None] * V.T


@numba.njit(cache=True)
def _transition(z, F_N, A_d, B_dT, CvA, beta, mu, alpha):
    """f(z, F_N) = A_d z + B_dT f_r(v_next, F_N) (module docstring), with the real-time step's
    implicit friction (``frictionrt.observer.step._implicit_v``). Allocates its result: offline only."""
    v_next = _implicit_v(CvA @ z, beta, F_N, mu, alpha)
    f_next, _ = _friction(v_next, F_N, mu, alpha)
    return A_d @ z + B_dT * f_next


class _Transition:
    """f(z, F_N) of the module docstring, filterpy's fx(x, dt, **fx_args) signature.

    F_N [N] comes as a keyword (filter) or from the attribute ``F_N`` (the RTS smoother calls
    fx(x, dt) without arguments: the caller sets it per tick)."""

    def __init__(self, design: ObserverDesign):
        p = design.params
        self.args = (np.ascontiguousarray(p.A_d), np.ascontiguousarray(p.B_dT), np.ascontiguousarray(p.CvA),
                     float(p.beta), float(p.mu), float(p.alpha))
        self.F_N = 0.0

    def __call__(self, z: np.ndarray, dt: float, F_N: float | None = None) -> np.ndarray:
        return _transition(z, float(self.F_N if F_N is None else F_N), *self.args)


def make_ukf(design: ObserverDesign, P0: np.ndarray | None = None) -> UnscentedKalmanFilter:
    """filterpy's UKF of the observer's model (module docstring), at z = 0 with covariance P0
    (default: the Kalman design's a-priori covariance P, the steady state of the linear filter,
    which is where the real-time observer's gain comes from)."""
    p = design.params
    n = len(p.M)
    C = np.asarray(p.C_meas)
    points = MerweScaledSigmaPoints(n, alpha=SIGMA_ALPHA, beta=SIGMA_BETA, kappa=SIGMA_KAPPA, sqrt_method=_psd_sqrt)
    ukf = UnscentedKalmanFilter(dim_x=n, dim_z=1, dt=design.dt, hx=lambda z: np.array([C @ z]),
                                fx=_Transition(design), points=points, sqrt_fn=_psd_sqrt)
    ukf.x = np.zeros(n)
    ukf.P = np.array(design.P if P0 is None else P0, dtype=float)
    ukf.Q = process_noise(design)
    ukf.R = np.array([[design.R]])
    # filterpy's update() uses the sigma points predict() left behind: the first update (of z_0
    # by y_0, before any predict) needs the prior's own
    ukf.sigmas_f = points.sigma_points(ukf.x, ukf.P)
    return ukf


def _check_inputs(design: ObserverDesign, v_meas, F_N) -> tuple[np.ndarray, np.ndarray]:
    y = np.asarray(v_meas, dtype=float).ravel()
    F = np.broadcast_to(np.asarray(F_N, dtype=float), y.shape).copy() if np.ndim(F_N) == 0 else \
        np.asarray(F_N, dtype=float).ravel()
    if y.shape != F.shape:
        raise ValueError(f"v_meas ({y.shape[0]} ticks) and F_N ({F.shape[0]} ticks) must have the same length")
    if len(y) < 2:
        raise ValueError("the record needs at least 2 ticks")
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(F))):
        raise ValueError("v_meas and F_N must be finite")
    if np.any(F < 0.0):
        raise ValueError(f"F_N must be >= 0 N (min {F.min():g} N)")
    return y, F


def ukf_run(design: ObserverDesign, v_meas, F_N, *, smooth: bool = True, P0: np.ndarray | None = None,
            progress: bool | None = None) -> OfflineEstimate:
    """The UKF (and, if smooth, its RTS smoother) over a record (module docstring).

    Parameters
    ----------
    design : the observer's design (``frictionrt.observer.kalman.design_observer``): model, noise covariances
    v_meas : (n,) measured tip velocity y_k [m/s] (the loop's ``v_tip_meas``)
    F_N : (n,) or scalar normal force F_N,k [N] (the loop's ``F_cell``, as the real-time observer)
    smooth : also run the RTS smoother backwards over the filtered states
    P0 : initial covariance of z_0 (default design.P); the initial state is 0 (at rest)
    progress : tqdm bar; None: on a terminal for records >= PROGRESS_MIN_STEPS ticks

    Raises ValueError for inputs of different lengths, non-finite values or F_N < 0.
    """
    y, F = _check_inputs(design, v_meas, F_N)
    n_t = len(y)
    ukf = make_ukf(design, P0)
    n = ukf.x.shape[0]
    fx = ukf.fx
    show = (n_t >= PROGRESS_MIN_STEPS) if progress is None else progress
    disable = None if (progress is None and show) else not show  # None: tqdm's own TTY check
    Xs = np.empty((n_t, n))
    Ps = np.empty((n_t, n, n))
    fx(np.zeros(n), design.dt, F_N=float(F[0]))  # compile or load the kernel outside the timing
    t0 = time.perf_counter()
    for k in tqdm(range(n_t), desc="UKF", unit="tick", disable=disable, leave=False):
        if k > 0:
            ukf.predict(F_N=F[k - 1])  # z_k|k-1 = f(z_k-1|k-1, F_N,k-1) (+ Q_d)
        ukf.update(y[k:k + 1])         # z_k|k
        Xs[k] = ukf.x
        Ps[k] = ukf.P
    t_f = (time.perf_counter() - t0) / n_t * 1e6
    if not smooth:
        return OfflineEstimate(Xs, Ps, None, None, t_f, float("nan"))
    # RTS, backwards: filterpy's rts_smoother calls fx(x, dt) without F_N, so it runs one
    # transition k -> k+1 at a time, on [z_k|k, z_k+1|n] with F_N,k set on the transition
    # (the same arithmetic as one call over the record: step k reads only the filtered z_k|k and
    # the smoothed z_k+1|n).
    xs = Xs.copy()
    ps = Ps.copy()
    t0 = time.perf_counter()
    for k in tqdm(range(n_t - 2, -1, -1), desc="RTS", unit="tick", disable=disable, leave=False):
        fx.F_N = F[k]
        x2, p2, _ = ukf.rts_smoother(xs[k:k + 2], ps[k:k + 2])
        xs[k] = x2[0]
        ps[k] = p2[0]
    t_s = (time.perf_counter() - t0) / max(n_t - 1, 1) * 1e6
    return OfflineEstimate(Xs, Ps, xs, ps, t_f, t_s)


def outputs(design: ObserverDesign, z: np.ndarray, F_N) -> tuple[np.ndarray, np.ndarray]:
    """(u_rel_hat [m], v_rel_hat [m/s]) of states z (n, 2N) at forces F_N (n,) [N]:
    v = C_v z, u = C_u z + D_u f_r(v, F_N) (the real-time observer's outputs)."""
    p = design.params
    v = z @ np.asarray(p.C_v)
    f = p.mu * np.asarray(F_N, dtype=float) * (2.0 / np.pi) * np.arctan(p.alpha * v)
    return z @ np.asarray(p.C_u) + p.D_u * f, v


def ukf_estimate(design: ObserverDesign, v_meas, F_N, *, smooth: bool = True,
                 progress: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """u_rel_hat [m] and v_rel_hat [m/s] at every tick of a record, from the UKF (causal) or, if
    smooth, its RTS smoother (non-causal, the best this model can do on the data).

    v_meas (n,) tip velocity [m/s], F_N (n,) or scalar normal force [N]; see ``ukf_run``."""
    _, F = _check_inputs(design, v_meas, F_N)
    est = ukf_run(design, v_meas, F, smooth=smooth, progress=progress)
    return outputs(design, est.z_smooth if smooth else est.z_filt, F)


def phasor(x: np.ndarray, freq_hz: float, dt: float, tail: float = TAIL) -> complex:
    """Complex amplitude X of the component at freq_hz [Hz] of x over its last `tail` share
    (least squares on cos, sin and an offset): x ~ Re(X e^{i 2 pi f t}) + c, t = k dt."""
    n = len(x)
    k = np.arange(n - max(int(tail * n), 2), n)
    w = 2 * np.pi * freq_hz * k * dt
    c, *_ = np.linalg.lstsq(np.column_stack([np.cos(w), np.sin(w), np.ones(len(k))]), x[k], rcond=None)
    return complex(c[0], -c[1])


def fundamental_error(x_hat: np.ndarray, x_true: np.ndarray, freq_hz: float, dt: float, tail: float = TAIL) -> float:
    """|X_hat - X_true| / |X_true| of the phasors at freq_hz (``phasor``): the error of the
    first harmonic alone, amplitude and phase together (0.1 is e.g. 10 % amplitude or 5.7 deg),
    which is what the laws' amplitude estimate (RT1) mostly sees; the NRMSE also counts the
    harmonics of stick-slip and the switching's ringing."""
    X_hat, X = phasor(x_hat, freq_hz, dt, tail), phasor(x_true, freq_hz, dt, tail)
    return abs(X_hat - X) / abs(X)


def compare_on_run(run_result, *, smooth: bool = True, tail: float = TAIL, design: ObserverDesign | None = None,
                   progress: bool | None = None) -> dict:
    """NRMSE of v_rel and u_rel on a closed-loop Run (``frictionrt.rt.loop.driver.run``) for

    * ``rt``: the real-time observer's logged estimates (``v_rel_hat``, ``u_rel_hat``; needs a
      run with ``--estimator observer``),
    * ``ukf``: the UKF (causal) on the run's ``v_tip_meas`` and ``F_cell``, the real-time
      observer's inputs,
    * ``rts``: its RTS smoother (if smooth),

    all against the plant's v_rel, u_rel low-passed without phase at
    ``observer.oracle_bandwidth_hz`` (``frictionrt.observer.accuracy.band_limited_truth``) over the same last
    `tail` share of the run.

    Two alignments of the truth:

    * ``v_rel_nrmse``, ``u_rel_nrmse``: at the same instant, as ``frictionrt.rt.loop.results.summary``
      reports the estimation error (comparable with ``frictionrt simulate``). Row k of a run's
      log holds the estimates at t_k but the plant's outputs after its step, at t_k+1
      (``frictionrt.rt.loop.tick``, ``frictionrt.plant.newmark._plant_step``): the estimate of row k+1 is compared with
      the truth of row k (``frictionrt.observer.accuracy.at_estimate_instant``);
    * ``v_rel_nrmse_rows``, ``u_rel_nrmse_rows``: row by row, one tick of lag (3.4 deg at 196 Hz,
      6.5 deg at 378 Hz): a perfect estimate of a sine would show 2 sin(pi f dt) (0.06 at
      196 Hz, 0.11 at 378 Hz).

    design: the observer's design the UKF runs (default ``design_observer(run.loop.cfg)``,
    which must be the design of the run's observer: pass the design explicitly for a run whose
    observer was built from another configuration, ``build_loop(..., observer_cfg=...)``).

    Returns {"v_rel_nrmse": {"rt", "ukf"[, "rts"]: float}, "u_rel_nrmse": {...},
    "v_rel_nrmse_aligned", "u_rel_nrmse_aligned" (the same figures, the older records' name),
    "v_rel_nrmse_rows": {...}, "u_rel_nrmse_rows": {...}, "v_rel_fund_error": {...},
    "u_rel_fund_error": {...} (``fundamental_error`` at the excitation frequency, aligned), "ticks": n,
    "ukf_us_per_step", "rts_us_per_step": wall time per tick [us]}.
    Raises ValueError for a run without the observer or a design that is not the run's.
    """
    loop = run_result.loop
    if loop.estimator != "observer":
        raise ValueError(f"compare_on_run needs a run with the observer (this one ran the {loop.estimator})")
    cfg = loop.cfg
    if design is None:
        design = design_observer(cfg)
        if not (np.allclose(design.params.M, loop.observer.M, rtol=1e-9, atol=0.0)
                and np.allclose(design.params.A_d, loop.observer.A_d, rtol=1e-9, atol=0.0)):
            raise ValueError("compare_on_run: the run's observer is not design_observer(run.loop.cfg) "
                             "(built from another observer_cfg?): pass design=design_observer(that cfg)")
    dt, f_c = cfg.dt_s, cfg.observer.oracle_bandwidth_hz
    v_true = band_limited_truth(run_result.signal("v_rel"), dt, f_c)
    u_true = band_limited_truth(run_result.signal("u_rel"), dt, f_c)
    F = run_result.signal("F_cell")
    est = ukf_run(design, run_result.signal("v_tip_meas"), F, smooth=smooth, progress=progress)
    cand = {"rt": (run_result.signal("u_rel_hat"), run_result.signal("v_rel_hat")),
            "ukf": outputs(design, est.z_filt, F)}
    if smooth:
        cand["rts"] = outputs(design, est.z_smooth, F)
    f0 = float(run_result.freq_hz)
    return {"v_rel_nrmse": {k: nrmse(*at_estimate_instant(v, v_true), tail) for k, (_, v) in cand.items()},
            "u_rel_nrmse": {k: nrmse(*at_estimate_instant(u, u_true), tail) for k, (u, _) in cand.items()},
            "v_rel_nrmse_aligned": {k: nrmse(*at_estimate_instant(v, v_true), tail) for k, (_, v) in cand.items()},
            "u_rel_nrmse_aligned": {k: nrmse(*at_estimate_instant(u, u_true), tail) for k, (u, _) in cand.items()},
            "v_rel_nrmse_rows": {k: nrmse(v, v_true, tail) for k, (_, v) in cand.items()},
            "u_rel_nrmse_rows": {k: nrmse(u, u_true, tail) for k, (u, _) in cand.items()},
            "v_rel_fund_error": {k: fundamental_error(v[1:], v_true[:-1], f0, dt, tail) for k, (_, v) in cand.items()},
            "u_rel_fund_error": {k: fundamental_error(u[1:], u_true[:-1], f0, dt, tail) for k, (u, _) in cand.items()},
            "ticks": len(F), "ukf_us_per_step": est.us_per_step_filter, "rts_us_per_step": est.us_per_step_smoother}
