"""The observer's linear model (SPEC section 5, paper Eq. 5-7), built at design time from the
same configuration as the plant.

The simplified structure: the plant's FE beams (``plant.structure``, unreduced) with

* the damper tied at the normal screw: the interface pairs within one pitch of that screw
  get the plant's stuck contact stiffnesses k_n (normal) and k_t (tangential), which is rigid
  for the modes the observer keeps (the plant's stuck pairs there never slip: 6000 N preload);
* no other normal contact;
* normal springs k_n around the adaptive screw: the pairs within one pitch of it that the
  screws close at F_N1 = F_min (the plant's static equilibrium; with the default structure the
  pair at 0.625 m: a spring also at 0.605 m, which is open there, put modes 3 and 4 at 202 and
  382 Hz against the passive damper's resonances at 196 and 370 Hz), tangentially free: the friction force f_r acts there as an input, on the adaptive screw's tangential
  row t (u_rel = t x), +f_r on the lower beam and -f_r on the upper one (generalised force
  -t^T f_r, opposing v_rel for f_r of the sign of v_rel).

Modal truncation to the first N modes (mass-normalised Phi_N, eigenfrequencies omega_i) with
modal damping zeta, state z = [q; q'] (2N):

    z' = A z + B_T f_r + B_F F_exc        A = [[0, I], [-Omega^2, -2 zeta Omega]]
                                          B_T = [0; -Phi_N^T t^T],  B_F = [0; Phi_N^T b_exc]
    y_meas = C_meas z                     tip velocity: [0, p_tip Phi_N]
    u_rel = C_u z + D_u f_r               C_u = [t Phi_N, 0]
    v_rel = C_v z                         C_v = [0, t Phi_N]

D_u is the static correction (residual flexibility) of the friction-to-u_rel path: the full
static compliance minus the part of the kept modes,

    D_u = -(t K^-1 t^T - sum_i (t phi_i)^2 / omega_i^2)   [m/N]   (sign: the force is -t^T f_r).

The excitation force is unknown to the observer: B_F only carries process noise in the
Kalman design (``observer.kalman``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from plant.model import PlantModel, build_plant, preloaded_pairs
from plant.structure import build_structure, interface_rows
from rt.common.config import Config, require_adaptive_screw


@dataclass(frozen=True)
class ObserverModel:
    """Continuous-time modal model of the observer (module docstring); SI units."""
    omega: np.ndarray    # (N,) kept eigenfrequencies [rad/s]
    zeta: float          # modal damping ratio [-]
    A: np.ndarray        # (2N, 2N) [1/s, 1/s^2]
    B_T: np.ndarray      # (2N,) friction force input [1/(kg)] (modal)
    B_F: np.ndarray      # (2N,) excitation force input (process noise only)
    C_meas: np.ndarray   # (2N,) tip velocity [m/s per modal unit]
    C_u: np.ndarray      # (2N,) u_rel
    C_v: np.ndarray      # (2N,) v_rel
    D_u: float           # static correction of u_rel per friction force [m/N]
    x_tied: np.ndarray   # interface positions tied at the normal screw [m]
    x_springs: np.ndarray  # positions of the normal springs around the adaptive screw [m]

    @property
    def modes_hz(self) -> np.ndarray:
        return self.omega / (2 * np.pi)

    @property
    def n_states(self) -> int:
        return self.A.shape[0]


def _near(x_pairs: np.ndarray, x: float, pitch: float) -> np.ndarray:
    """Interface pair positions within one pitch of x (a little slack for round-off)."""
    return x_pairs[np.abs(x_pairs - x) <= pitch * (1 + 1e-9)]


def build_observer_model(cfg: Config, plant: PlantModel | None = None) -> ObserverModel:
    """The observer's linear model from the configuration (module docstring); ``plant`` is the
    plant built from the same cfg if the caller has it (its static equilibrium is used).

    Raises ValueError if the tied structure is not fixed against rigid-body motion, or if the
    configuration asks for more modes than it has.
    """
    st = build_structure(cfg)
    p = cfg.plant
    itf = p.interface
    K = sla.block_diag(*(s.K for s in st.subs))
    M = sla.block_diag(*(s.M for s in st.subs))
    normal = next(s for s in p.screws if not s.adaptive)
    adaptive = require_adaptive_screw(cfg, "the observer")
    x_tied = _near(st.x_pairs, normal.x_m, itf.pitch_m)
    plant = build_plant(cfg) if plant is None else plant
    closed = st.x_pairs[preloaded_pairs(plant, cfg.tracking.F_min_N)]
    x_springs = _near(closed, adaptive.x_m, itf.pitch_m)
    if len(x_tied) == 0 or len(x_springs) == 0:
        raise ValueError("observer: no interface pair within one pitch of the "
                         f"{'normal' if len(x_tied) == 0 else 'adaptive'} screw; check plant.interface")
    for x in x_tied:
        r_n, r_t = interface_rows(cfg, st.subs, x)
        K += itf.k_n * np.outer(r_n, r_n) + itf.k_t * np.outer(r_t, r_t)
    for x in x_springs:
        r_n, _ = interface_rows(cfg, st.subs, x)
        K += itf.k_n * np.outer(r_n, r_n)
    N = cfg.observer.n_modes
    if N > K.shape[0]:
        raise ValueError(f"observer.n_modes = {N}: the structure has only {K.shape[0]} DOFs")
    lam, Phi = sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T), subset_by_index=[0, N - 1])
    if lam[0] <= (2 * np.pi * 0.1) ** 2:
        raise ValueError(f"observer: the tied structure has a mode at {np.sqrt(max(lam[0], 0)) / 2 / np.pi:.3g} Hz "
                         "(rigid-body motion): the clamps and the tie at the normal screw must fix it")
    omega = np.sqrt(lam)
    zeta = cfg.observer.modal_damping
    t = st.u_rel_row
    tip = st.point_rows[st.point_names.index("tip")] if "tip" in st.point_names else None
    if tip is None:
        raise ValueError("observer: the measurement needs a point named 'tip' in plant.points")
    tPhi = t @ Phi
    Z = np.zeros((N, N))
    A = np.block([[Z, np.eye(N)], [-np.diag(lam), -np.diag(2 * zeta * omega)]])
    zN = np.zeros(N)
    static_full = float(t @ np.linalg.solve(K, t))
    static_kept = float(np.sum(tPhi**2 / lam))
    return ObserverModel(
        omega=omega, zeta=zeta, A=A,
        B_T=np.concatenate([zN, -tPhi]), B_F=np.concatenate([zN, Phi.T @ st.b_exc]),
        C_meas=np.concatenate([zN, tip @ Phi]), C_u=np.concatenate([tPhi, zN]), C_v=np.concatenate([zN, tPhi]),
        D_u=-(static_full - static_kept), x_tied=x_tied, x_springs=x_springs)
