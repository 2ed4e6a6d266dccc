"""The observer's linear model (SPEC section 5, paper Eq. 5-7), built at design time from the
same configuration as the plant.

The simplified structure: the plant's FE beams (``frictionrt.plant.structure``, unreduced) with

* the damper tied at the normal screw: the interface under that screw's pressure cone
  (|x - x_s| <= R_c, plant/bolts.py) gets the plant's stuck contact stiffnesses per unit area
  k_n_area (normal) and k_t_area (tangential), given to the contact points by the footprint's
  hat-function integrals (plant/tributary.py, so that the tie is the same physical area at any
  pitch), which is rigid for the modes the observer keeps (the plant's stuck pairs there never
  slip: 6000 N preload);
* no other normal contact;
* normal springs k_n_area around the adaptive screw: the footprint of its cone on the points
  that the screws close at F_N1 = F_min (the plant's static equilibrium; a spring on an open
  point put modes 3 and 4 at 202 and 382 Hz against the passive damper's resonances at 196 and
  370 Hz at the earlier 20 mm pairs), tangentially free: the friction force f_r acts there as an input, on the adaptive screw's tangential
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
Kalman design (``frictionrt.observer.kalman``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla

from frictionrt.plant.bolts import cone_footprint
from frictionrt.plant.model import PlantModel, build_plant, preloaded_pairs
from frictionrt.plant.structure import build_structure, interface_rows, interface_width, screw_cone_radius
from frictionrt.rt.common.config import Config, require_adaptive_screw


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
    l_tied: np.ndarray   # length of the cone's footprint each of them stands for [m]
    x_springs: np.ndarray  # positions of the normal springs around the adaptive screw [m]
    l_springs: np.ndarray  # length of the footprint each of them stands for [m]

    @property
    def modes_hz(self) -> np.ndarray:
        return self.omega / (2 * np.pi)

    @property
    def n_states(self) -> int:
        return self.A.shape[0]


def _footprint(cfg: Config, x_pairs: np.ndarray, screw) -> tuple[np.ndarray, np.ndarray]:
    """(positions [m], footprint lengths [m]) of the contact points under ``screw``'s pressure
    cone (plant/bolts.py ``cone_footprint``), the points with a share of it only."""
    length = cone_footprint(x_pairs, screw.x_m, screw_cone_radius(cfg, screw))
    hit = length > 0.0
    return x_pairs[hit], length[hit]


def build_observer_model(cfg: Config, plant: PlantModel | None = None,
                         spring_scale: float | None = None) -> ObserverModel:
    """The observer's linear model from the configuration (module docstring); ``plant`` is the
    plant built from the same cfg if the caller has it (its static equilibrium is used).
    ``spring_scale``: the normal springs under the adaptive screw's cone at spring_scale k_n_area
    (an effective normal stiffness of a contact that partly opens over the cycle; 1: the stuck
    linearisation, SPEC 5's model; not on an imported structure); None: ``cfg.observer.spring_scale``.

    Raises ValueError if the tied structure is not fixed against rigid-body motion, if the
    configuration asks for more modes than it has, or for a spring_scale other than 1 on an
    imported structure.
    """
    from frictionrt.plant.se_plant import SEPlant
    spring_scale = cfg.observer.spring_scale if spring_scale is None else float(spring_scale)
    if isinstance(plant, SEPlant):
        if spring_scale != 1.0:
            raise ValueError(f"observer.spring_scale = {spring_scale:g}: the softened springs are the built-in "
                             "beams' model only; use observer.spring_scale=1 with an imported structure")
        return build_observer_model_se(cfg, plant)
    st = build_structure(cfg)
    p = cfg.plant
    itf = p.interface
    K = sla.block_diag(*(s.K for s in st.subs))
    M = sla.block_diag(*(s.M for s in st.subs))
    normal = next(s for s in p.screws if not s.adaptive)
    adaptive = require_adaptive_screw(cfg, "the observer")
    x_tied, l_tied = _footprint(cfg, st.x_pairs, normal)
    plant = build_plant(cfg) if plant is None else plant
    closed = preloaded_pairs(plant, cfg.tracking.F_min_N)
    x_springs, l_springs = _footprint(cfg, st.x_pairs[closed], adaptive)
    if len(x_springs) == 0:
        raise ValueError("observer: no closed interface pair under the adaptive screw's pressure cone at "
                         "F_N1 = tracking.F_min_N; check plant.interface")
    width = interface_width(cfg)
    for x, length in zip(x_tied, l_tied):
        r_n, r_t = interface_rows(cfg, st.subs, x)
        K += width * length * (itf.k_n_area * np.outer(r_n, r_n) + itf.k_t_area * np.outer(r_t, r_t))
    k_springs = itf.k_n_area if spring_scale == 1.0 else itf.k_n_area * spring_scale
    for x, length in zip(x_springs, l_springs):
        r_n, _ = interface_rows(cfg, st.subs, x)
        K += width * length * k_springs * np.outer(r_n, r_n)
    N = cfg.observer.n_modes
    if N > K.shape[0]:
        raise ValueError(f"observer.n_modes = {N}: the structure has only {K.shape[0]} DOFs")
    lam, Phi = sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T), subset_by_index=[0, N - 1])
    if lam[0] <= (2 * np.pi * 0.1) ** 2:
        raise ValueError(f"observer: the tied structure has a mode at {np.sqrt(max(lam[0], 0)) / 2 / np.pi:.3g} Hz "
                         "(rigid-body motion): the clamps and the tie at the normal screw must fix it")
    t = st.u_rel_row
    tip = st.point_rows[st.point_names.index("tip")] if "tip" in st.point_names else None
    if tip is None:
        raise ValueError("observer: the measurement needs a point named 'tip' in plant.points")
    return modal_model(K, lam, Phi, cfg.observer.modal_damping, t, tip, st.b_exc, x_tied, l_tied, x_springs,
                       l_springs)


def modal_model(K: np.ndarray, lam: np.ndarray, Phi: np.ndarray, zeta: float, t: np.ndarray, tip: np.ndarray,
                b_exc: np.ndarray, x_tied: np.ndarray, l_tied: np.ndarray, x_springs: np.ndarray,
                l_springs: np.ndarray) -> ObserverModel:
    """The observer's modal state space (module docstring) from the tied stiffness K, the N kept
    modes (eigenvalues lam [rad^2/s^2], mass-normalised shapes Phi (n, N)), the modal damping zeta,
    u_rel's row t, the measured point's row tip and the excitation's b_exc (all (n,), in K's
    coordinates): A, B_T, B_F, C_meas, C_u, C_v and the static correction D_u. The footprint arrays
    are carried into the ``ObserverModel`` for plots."""
    N = len(lam)
    omega = np.sqrt(lam)
    tPhi = t @ Phi
    Z = np.zeros((N, N))
    A = np.block([[Z, np.eye(N)], [-np.diag(lam), -np.diag(2 * zeta * omega)]])
    zN = np.zeros(N)
    static_full = float(t @ np.linalg.solve(K, t))
    static_kept = float(np.sum(tPhi**2 / lam))
    return ObserverModel(
        omega=omega, zeta=zeta, A=A,
        B_T=np.concatenate([zN, -tPhi]), B_F=np.concatenate([zN, Phi.T @ b_exc]),
        C_meas=np.concatenate([zN, tip @ Phi]), C_u=np.concatenate([tPhi, zN]), C_v=np.concatenate([zN, tPhi]),
        D_u=-(static_full - static_kept), x_tied=x_tied, l_tied=l_tied, x_springs=x_springs,
        l_springs=l_springs)


LAW_PARTICIPATION = 1e-6   # a mode the laws act on: |t phi_i| >= this x the largest among the computed modes
#                            (a symmetric structure's lateral and torsion modes: 1e-12..1e-9; the first bending
#                            mode of the 3-D reference: 1.6e-3)
LINEARISATION_FORCES = 8  # F_N1 on a geometric grid over [F_min, F_max]: the first that closes a point at the adaptive bolt
AT_BOLT_WEIGHT = 0.1       # a point at the adaptive bolt: its weight in u_rel_row >= this x the largest weight


def adaptive_points(cfg: Config, plant, F_N1: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(closed, at_adaptive): boolean masks over an imported structure's contact points. closed: the
    points the bolts close at F_N1 (default tracking.F_min_N; the plant's static equilibrium). at_adaptive:
    the closed points nearer to the adaptive bolt than to the preload, i.e. nearer (``contact_xyz``)
    to x_A, the centre of the points that make up ``u_rel_row``, than to x_N, the centre of the
    closed points' normal forces at F_min (the preload's centre, which the ordinary bolts
    dominate); the analogue of the built-in model's pressure-cone footprint around the adaptive
    screw. The points of u_rel_row are those of the least-squares weights
    u_rel_row = sum_i w_i contact_rows[i, 1] with w_i >= ``AT_BOLT_WEIGHT`` max(w) (the format
    documents u_rel_row as the area-weighted mean first-direction slip under the adaptive bolt's
    head); x_A is their w-weighted centre. Without ``contact_xyz``: those points, where closed."""
    p = plant.params
    se = plant.se
    d = 1 + p.nt
    x0 = plant.initial_state(cfg.tracking.F_min_N if F_N1 is None else F_N1)
    g_n = x0[plant.state_slots()["g"]][0::d]
    closed = g_n < 0.0
    w = np.linalg.lstsq(se.contact_rows[:, 1, :].T, se.u_rel_row, rcond=None)[0]
    under = w >= AT_BOLT_WEIGHT * w.max()
    if se.contact_xyz is None:
        return closed, closed & under
    xyz = se.contact_xyz
    f = p.k_n * np.maximum(-g_n, 0.0)
    x_A = (w[under] @ xyz[under]) / w[under].sum()
    x_N = (f @ xyz) / f.sum()
    near_A = np.linalg.norm(xyz - x_A, axis=1) < np.linalg.norm(xyz - x_N, axis=1)
    return closed, closed & near_A


def build_observer_model_se(cfg: Config, plant) -> ObserverModel:
    """The observer's linear model of an imported structure (``plant.se_plant.SEPlant``), in the
    superelement's own coordinates q (M, K, and the adaptive bolt's spring k_b r r^T):

    * the contact linearised at the static equilibrium at F_N1 = tracking.F_min_N (or, if no point
      at the adaptive bolt is closed there, at the first of ``LINEARISATION_FORCES`` forces
      geometrically spaced up to tracking.F_max_N that closes one: a coarsened interface's
      clusters may open where the fine one's points are closed): the closed
      points stuck (k_n on g_n, k_t on each tangential gap) except those at the adaptive bolt
      (``adaptive_points``), which keep their normal spring and their second tangential one but are
      free along the first tangential direction (u_rel's: the friction f_r acts there); open points
      carry nothing;
    * the friction force f_r acts on the superelement's ``u_rel_row`` t (the documented direction
      at the adaptive bolt) as the generalised force -t^T f_r; the measurement is the velocity of
      the sensor named 'tip', the excitation the first of ``excitation``;
    * modal truncation to the first ``observer.n_modes`` modes the laws act on: those with
      |t phi_i| >= ``LAW_PARTICIPATION`` x the largest among the lowest max(4 N + 20, 40) (a 3-D
      structure's lateral bending and torsion modes, which u_rel does not see, are skipped); D_u the static correction of u_rel
      with the full compliance (module docstring).

    Raises ValueError if no point at the adaptive bolt closes up to F_max, the tied structure moves as a
    rigid body, the superelement has no u_rel_row, no sensor 'tip' or no excitation, or has fewer
    such modes than asked for."""
    se = plant.se
    if se.u_rel_row is None or not np.any(se.u_rel_row):
        raise ValueError("observer: the superelement has no u_rel_row (the relative tangential displacement at "
                         "the adaptive bolt the laws act on; docs/superelement.md)")
    if "tip" not in se.sensor_names:
        raise ValueError(f"observer: the measurement needs a sensor named 'tip'; the superelement's sensors: "
                         f"{list(se.sensor_names)}")
    if not se.excitation.size:
        raise ValueError("observer: the superelement has no excitation row")
    itf = cfg.plant.interface
    t_ = cfg.tracking
    for F_lin in np.geomspace(t_.F_min_N, t_.F_max_N, LINEARISATION_FORCES) if t_.F_min_N > 0 else [t_.F_max_N]:
        closed, at = adaptive_points(cfg, plant, float(F_lin))
        if at.any():
            break
    else:
        raise ValueError(f"observer: no contact point near the adaptive bolt is closed at any F_N1 in "
                         f"[{t_.F_min_N:g}, {t_.F_max_N:g}] N (tracking.F_min_N, F_max_N); check plant.interface, the "
                         "bolts' rows and u_rel_row (a coarser interface: --clusters)")
    K = se.K.copy()
    if se.adaptive_row is not None:
        K += float(se.adaptive_k) * np.outer(se.adaptive_row, se.adaptive_row)
    d = se.friction_dims + 1
    k_n = itf.k_n_area * se.contact_area
    k_t = itf.k_t_area * se.contact_area
    for i in np.flatnonzero(closed):
        R = se.contact_rows[i]
        K += k_n[i] * np.outer(R[0], R[0])
        for a in range(2 if at[i] else 1, d):   # at the adaptive bolt: free along t1 (u_rel's direction)
            K += k_t[i] * np.outer(R[a], R[a])
    M = se.M
    N = cfg.observer.n_modes
    n_eig = min(se.n, max(4 * N + 20, 40))
    lam, Phi = sla.eigh(0.5 * (K + K.T), 0.5 * (M + M.T), subset_by_index=[0, n_eig - 1])
    if lam[0] <= (2 * np.pi * 0.1) ** 2:
        raise ValueError(f"observer: the tied structure has a mode at {np.sqrt(max(lam[0], 0)) / 2 / np.pi:.3g} Hz "
                         "(rigid-body motion): the points the bolts close must hold it")
    t = se.u_rel_row
    part = np.abs(t @ Phi)
    keep = np.flatnonzero(part >= LAW_PARTICIPATION * part.max())[:N]
    if len(keep) < N:
        raise ValueError(f"observer.n_modes = {N}: the imported structure has only {len(keep)} modes the laws act "
                         f"on among its lowest {n_eig}")
    lam, Phi = lam[keep], Phi[:, keep]
    tip = se.sensor_rows[list(se.sensor_names).index("tip")]
    x = se.contact_xyz[:, 0] if se.contact_xyz is not None else np.arange(se.n_points, dtype=float)
    area = se.contact_area
    return modal_model(K, lam, Phi, cfg.observer.modal_damping, t, tip, se.excitation[0], x[closed & ~at],
                       area[closed & ~at], x[at], area[at])
