"""Design time: discretise the observer's model exactly and design its Kalman gain (SPEC 5).

Discretisation: zero-order hold at the controller step dt (``scipy.linalg.expm`` of the
augmented matrix), exact for inputs held over a tick, which is what the loop gives:

    z_{k+1} = A_d z_k + B_dT f_r,k + B_dF F_k          A_d = e^{A dt}, B_d = int_0^dt e^{A s} ds B

Kalman gain: ``control.dlqe`` on that discrete model (not ``lqe`` on the continuous one then a
discretisation): the noise that matters enters per tick (the unknown excitation held over a
tick, the friction model's error, the sampled velocity), and the discrete Riccati equation
gives the optimal gain of the sampled system without an approximation of Q_d. Process noise
inputs G = [B_dF, B_dT] with covariance diag(sigma_F^2, sigma_T^2) [N^2]
(``observer.exc_noise_N``, ``observer.fric_noise_N``), measurement noise sigma_v^2 [(m/s)^2]
(``observer.meas_noise_m_s``); linearised at v_rel = 0, F_N = 0 (no friction).

``dlqe`` returns the predictor-form gain L = A_d P C^T (C P C^T + R)^-1 and the a-priori
covariance P. The run-time step uses the filter (current) form, so the estimate at tick k
already contains the measurement of tick k (no extra tick of delay, 3.5 deg at 200 Hz):

    M = P C^T (C P C^T + R)^-1,   L = A_d M   (checked at design time)

Friction in the run-time step (``frictionrt.observer.step``) is implicit in v_rel (backward Euler on the
friction term, ZOH otherwise): f_r is stiff for large alpha F_N (its slope mu F_N (2/pi) alpha
at v = 0 reaches 1.5e5 N s/m at F_max and alpha = 2000 s/m), and an explicit ZOH of it would be
unstable. ``discrete_eigenvalues`` gives the linearised discrete observer's eigenvalues with
the friction slope at F_N for both treatments.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import control
import numpy as np
from scipy.signal import cont2discrete

from frictionrt.observer.model import ObserverModel, build_observer_model
from frictionrt.rt.common.config import Config


class ObserverParams(NamedTuple):
    """Constant arrays of the run-time observer step (``frictionrt.observer.step._observer_step``)."""
    A_d: np.ndarray      # (n, n)
    B_dT: np.ndarray     # (n,) friction input over a tick
    M: np.ndarray        # (n,) filter-form Kalman gain [per m/s]
    L: np.ndarray        # (n,) predictor-form gain A_d M
    C_meas: np.ndarray   # (n,)
    C_u: np.ndarray      # (n,)
    C_v: np.ndarray      # (n,)
    CvA: np.ndarray      # (n,) C_v A_d
    beta: float          # C_v B_dT < 0: v_rel change per friction force over a tick [m/s/N]
    D_u: float           # static correction [m/N]
    mu: float            # [-]
    alpha: float         # [s/m]


@dataclass(frozen=True)
class ObserverDesign:
    """The designed observer: model, discrete matrices, gains and their checks."""
    model: ObserverModel
    params: ObserverParams
    L: np.ndarray                  # (n,) predictor-form gain from dlqe
    P: np.ndarray                  # (n, n) a-priori error covariance
    Q: np.ndarray                  # (2, 2) process noise covariance [N^2]
    R: float                       # measurement noise variance [(m/s)^2]
    eig_error_continuous: np.ndarray  # log(eig(A_d - L C)) / dt [1/s]: continuous equivalents
    dt: float

    def summary(self, F_max: float) -> dict:
        """Design figures (JSON-ready): kept modes, gain norms, eigenvalue moduli."""
        lin0 = discrete_eigenvalues(self, 0.0)
        imp = discrete_eigenvalues(self, F_max)
        exp = discrete_eigenvalues(self, F_max, implicit=False)
        return {
            "modes_hz": [float(f) for f in self.model.modes_hz], "n_states": self.model.n_states,
            "zeta": self.model.zeta, "D_u_m_per_n": self.model.D_u,
            "x_tied_m": [float(x) for x in self.model.x_tied], "x_springs_m": [float(x) for x in self.model.x_springs],
            "gain_norm_filter": float(np.linalg.norm(self.params.M)), "gain_norm_predictor": float(np.linalg.norm(self.L)),
            "Q_n2": np.diag(self.Q).tolist(), "R_m2_s2": self.R,
            "max_abs_eig_discrete": float(np.max(np.abs(lin0))),
            "max_abs_eig_discrete_friction_fmax": float(np.max(np.abs(imp))),
            "max_abs_eig_discrete_friction_fmax_explicit": float(np.max(np.abs(exp))),
            "max_real_eig_continuous_error": float(np.max(self.eig_error_continuous.real)),
            "alpha_s_m": self.params.alpha, "mu": self.params.mu, "F_max_n": F_max,
        }


def zoh(A: np.ndarray, B: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Exact zero-order-hold discretisation over dt [s]: (e^{A dt}, int_0^dt e^{A s} ds B), by
    ``scipy.signal.cont2discrete`` (the same expm of the augmented matrix the hand-written
    version took: A_d and B_d bit-identical for the observer model)."""
    n, m = A.shape[0], B.shape[1]
    A_d, B_d, *_ = cont2discrete((A, B, np.zeros((1, n)), np.zeros((1, m))), dt, method="zoh")
    return A_d, B_d


def design_observer(cfg: Config, plant=None, spring_scale: float | None = None) -> ObserverDesign:
    """Model, exact discretisation at cfg.dt_s, Kalman gain (module docstring); ``plant``: the
    plant built from cfg, if at hand (``frictionrt.observer.model.build_observer_model``, as is
    ``spring_scale``, the model's normal springs under the adaptive screw; None:
    ``cfg.observer.spring_scale``, whose default 1 is SPEC 5's model).

    Raises ValueError if the error dynamics would not be stable, without friction or linearised
    with it at any F_N in [0, F_max] (``discrete_eigenvalues``), or if the friction path has the
    wrong sign (a model error in the configuration)."""
    model = build_observer_model(cfg, plant, spring_scale)
    o = cfg.observer
    dt = cfg.dt_s
    A_d, B_d = zoh(model.A, np.column_stack([model.B_T, model.B_F]), dt)
    B_dT, B_dF = B_d[:, 0], B_d[:, 1]
    C = model.C_meas[None, :]
    Q = np.diag([o.exc_noise_N**2, o.fric_noise_N**2])
    R = o.meas_noise_m_s**2
    L, P, E = control.dlqe(A_d, np.column_stack([B_dF, B_dT]), C, Q, [[R]])
    L = np.asarray(L).ravel()
    P = np.asarray(P)
    M = (P @ C.T).ravel() / float((C @ P @ C.T)[0, 0] + R)
    if not np.allclose(A_d @ M, L, rtol=1e-6, atol=1e-12 * np.max(np.abs(L))):
        raise RuntimeError("observer design: the predictor gain from dlqe is not A_d M (python-control changed?)")
    if np.max(np.abs(E)) >= 1.0:
        raise ValueError(f"observer design: error dynamics not stable (max |eig(A_d - L C)| = {np.max(np.abs(E)):.6f}); "
                         "check observer.*_noise values")
    beta = float(model.C_v @ B_dT)
    if beta >= 0.0:
        raise ValueError("observer design: the friction force does not oppose v_rel (C_v B_dT >= 0)")
    eig_c = np.log(np.asarray(E, dtype=complex)) / dt  # continuous equivalents of the error poles
    params = ObserverParams(A_d=A_d, B_dT=B_dT, M=M, L=L.copy(), C_meas=model.C_meas.copy(), C_u=model.C_u.copy(),
                            C_v=model.C_v.copy(), CvA=model.C_v @ A_d, beta=beta, D_u=float(model.D_u),
                            mu=float(o.mu), alpha=float(o.alpha_s_m))
    for a in params:
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    design = ObserverDesign(model, params, L, P, Q, R, eig_c, dt)
    for F_N in np.linspace(0.0, cfg.tracking.F_max_N, 7):
        rho = np.max(np.abs(discrete_eigenvalues(design, F_N)))
        if rho >= 1.0:
            raise ValueError(f"observer design: unstable with the friction at F_N = {F_N:g} N (max |eig| = {rho:.6f}); "
                             f"raise observer.fric_noise_N (now {o.fric_noise_N:g} N) to >= 5 x observer.exc_noise_N "
                             f"({o.exc_noise_N:g} N) or lower observer.alpha_s_m ({o.alpha_s_m:g} s/m)")
    return design


def discrete_eigenvalues(design: ObserverDesign, F_N: float, implicit: bool = True) -> np.ndarray:
    """Eigenvalues of the run-time observer linearised at v_rel = 0 with the friction slope
    c = mu F_N (2/pi) alpha [N s/m], per tick (z_pred -> z_pred):

        implicit (run time):  T = (I + c/(1 - beta c) B_dT C_v) A_d (I - M C)
        explicit ZOH:         T = (A_d + c B_dT C_v) (I - M C)
    """
    p = design.params
    c = p.mu * F_N * (2 / np.pi) * p.alpha
    n = len(p.M)
    I_MC = np.eye(n) - np.outer(p.M, p.C_meas)
    if implicit:
        T = (np.eye(n) + c / (1 - p.beta * c) * np.outer(p.B_dT, p.C_v)) @ p.A_d @ I_MC
    else:
        T = (p.A_d + c * np.outer(p.B_dT, p.C_v)) @ I_MC
    return np.linalg.eigvals(T)
