"""Design time: the amplitude-following observer (``Estimator.AMPLITUDE``), a second estimator
kind beside the paper's (docs/observer.md, "The amplitude-following observer").

The paper's observer (``frictionrt.observer.kalman``) has one linear model, the plant linearised at
F_N1 = F_min with the adaptive joint sliding. The plant's resonances fall with the vibration level
(the other contacts slip and gape over the cycle): its passive step-sine peaks lie below that
linearisation, by an amount that grows with the amplitude. This kind keeps the paper's structure,
its mode shapes, friction law and Kalman gain M, and lets each kept mode's frequency follow that
mode's own amplitude:

    a_i = |t phi_i| sqrt(q_i^2 + (q_i' / omega_i)^2)          mode i's share of u_rel's amplitude [m]
    omega_i(a_i) = r_i(a_i) omega_i,   r_i piecewise linear in a_i on the grid ``AMP_GRID_M``

with r_i from the plant's own passive peaks (the peak over the plant's sliding-joint linearisation
at F_min, ``frictionrt.plant.modes.sliding_joint_hz``, against the passive u_rel amplitude at that
peak; r = 1 at a = 0, the linearisation, and held beyond the last point): on the default plant the
step-sine's (``PLANT_PEAKS``), on another the harmonic balance's
(``frictionrt.observer.amplitude_schedule``; ``schedule_peaks`` chooses). Modes without a point
keep r = 1.

In modal coordinates the model is a set of decoupled 2 x 2 blocks, so the exact zero-order hold of
mode i at a grid amplitude is a 2 x 2 matrix and a 2-vector (the friction input's column):

    [q_i; q_i']_{k+1} = Ad_i [q_i; q_i']_k|k + bd_i f_r           Ad_i = e^{A_i dt},  A_i = [[0, 1], [-w^2, -2 zeta w]]
                                                                   bd_i = int_0^dt e^{A_i s} ds [0; -t phi_i]

``AmplitudeParams.blocks[i, j]`` = (Ad_i[0,0], Ad_i[0,1], Ad_i[1,0], Ad_i[1,1], bd_i[0], bd_i[1], p_i) at
AMP_GRID_M[j] (p_i the participation, below); the run-time step (``frictionrt.observer.amplitude_step``)
interpolates those seven numbers
linearly between the two grid amplitudes around a_i, per mode per tick (scalar work: no matrix is
formed, inverted or exponentiated in the tick). Everything else is the paper's step: filter-form
update with the nominal gain M, implicit friction in v_rel (now beta = sum_i t phi_i bd_i[1] < 0,
scheduled), the static correction D_u.

Each mode also carries a participation p_i(a_i) (``participation``, the blocks' seventh column): the
factor on its rows of C_u and C_v (u_rel_hat and v_rel_hat, and the friction's end-of-tick velocity)
and on its friction input bd_i (the generalised force -p_i t phi_i f_r). The plant's u_rel per tip
velocity grows with the amplitude where a linear model's is constant (``PLANT_RATIOS``); p_i is chosen
so that the observer, as a linear filter from the measured tip velocity to u_rel_hat, has the plant's
ratio at each measured amplitude. Modes without points keep p_i = 1, and then the step is the one
without it, bit for bit.

The gain M stays the paper's: the offline UKF with a time-varying gain matched the constant gain
within 0.02 in NRMSE(v_rel) (docs/observer.md, "Where the error comes from"), so the gain is not
what limits. ``design_amplitude`` checks that the error dynamics stay stable with M at every
grid amplitude, all modes moved together.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import scipy.linalg as sla

from frictionrt.observer.kalman import ObserverDesign, design_observer
from frictionrt.rt.common.config import Config

# Grid of a mode's share of the u_rel amplitude [m] on which the blocks are designed.
AMP_GRID_M = (0.0, 0.5e-6, 1.0e-6, 2.0e-6, 4.0e-6, 8.0e-6, 16.0e-6, 32.0e-6, 64.0e-6, 128.0e-6, 256.0e-6)

# The plant's passive step-sine peaks (the full reproduction's, ``frictionrt reproduce``; the passive
# u_rel amplitude at each from ``python -m benchmarks.observer_amplitude --schedule``), as
# mode -> ((u0 [m], peak [Hz] over the sliding-joint linearisation's frequency [Hz]), ...).
# Measured on the default configuration at 5, 10 and 20 N. Left out: mode 3 at 20 N (its 186 Hz peak
# is a gaping branch the passive run from rest does not reach: u0 4.8 um, below the 10 N point's
# 12.4); mode 4 at 20 N (not measured by the reproduction); mode 5 (its peak, 0.990 of the
# linearisation at 1.5-4.5 um, is the passive joint's; under a law that presses the joint the mode
# moves up, and the model moved onto the passive peak is worse: docs/observer.md).
# Another plant gets its own schedule by harmonic balance (``schedule_peaks``).
PLANT_PEAKS: dict[int, tuple[tuple[float, float], ...]] = {
    2: ((25.956e-6, 0.98990), (66.093e-6, 0.98780), (255.520e-6, 0.98682)),
    3: ((4.574e-6, 0.99111), (12.394e-6, 0.98307)),
    4: ((1.602e-6, 0.98500), (4.889e-6, 0.97247)),
}


# The plant's ratio rho = U_rel / V_meas (first harmonics of the damper's relative displacement and of
# the measured tip velocity, the observer's input) against the u_rel amplitude, as
# mode -> ((f [Hz], U_rel [m], rho [s]), ...): mode 5 at its passive step-sine peak, the hysteresis
# law at 5 and 10 N (``python -m benchmarks.observer_mode5 --plant-ratios``). The truth's ratio grows
# with the amplitude at a fixed frequency (the contact under the adaptive screw opens over more of the
# cycle); a linear model's is constant. Modes 2-4 have none (their u0 error is within 3.5 % without).
# The schedule's only coordinate is the amplitude: a point at another frequency (mode 5's 20 N peak,
# 610.86 Hz) moves the error from that cell to the cells beside it (docs/observer.md section 11).
PLANT_RATIOS: dict[int, tuple[tuple[float, float, float], ...]] = {
    5: ((615.87, 1.5289e-6, 16.1149e-6), (615.87, 2.4964e-6, 17.4504e-6)),
}


class AmplitudeParams(NamedTuple):
    """Constant arrays of the amplitude-following step (module docstring); empty (grid of size 0)
    when the kind does not run."""
    grid: np.ndarray       # (G,) amplitudes of a mode's share of u_rel [m], ascending, grid[0] = 0
    blocks: np.ndarray     # (N, G, 7) per mode and grid amplitude: Ad (4, row-major), bd (2) and the
    #                        participation p_i (the factor on mode i's rows of C_u, C_v and on its bd; 1: the model's)
    scale: np.ndarray      # (N,) |t phi_i| [m per modal unit]
    inv_omega: np.ndarray  # (N,) 1 / omega_i of the linear model [s]
    k_j: float             # > 0: the joint as a Jenkins element of this stiffness [N/m] (state slot 2N: the
    #                        slider's position [m]); 0: the paper's regularised Coulomb force


def no_amplitude(n_modes: int = 0) -> AmplitudeParams:
    """Parameters of size 0 (same types): the tick takes the paper's step."""
    return AmplitudeParams(np.zeros(0), np.zeros((n_modes, 0, 7)), np.zeros(n_modes), np.zeros(n_modes), 0.0)


def joint_stiffness(cfg: Config, model) -> float:
    """The adaptive joint's stuck tangential stiffness [N/m]: k_t_area over the footprint of the
    closed pairs under the adaptive screw's cone (the model's normal springs' footprint)."""
    from frictionrt.plant.structure import interface_width
    return float(cfg.plant.interface.k_t_area * interface_width(cfg) * np.sum(model.l_springs))


def frequency_ratios(n_modes: int, grid=AMP_GRID_M, peaks=None) -> np.ndarray:
    """(N, G) r_i(a_j): 1 at a = 0, piecewise linear through ``peaks`` (``PLANT_PEAKS``), held
    beyond the last measured amplitude; 1 for a mode without measured peaks."""
    peaks = PLANT_PEAKS if peaks is None else peaks
    g = np.asarray(grid, dtype=float)
    r = np.ones((n_modes, len(g)))
    for mode, pts in peaks.items():
        i = mode - 1
        if i >= n_modes or not pts:
            continue
        a = np.concatenate([[0.0], [p[0] for p in pts]])
        ratio = np.concatenate([[1.0], [p[1] for p in pts]])
        order = np.argsort(a)
        r[i] = np.interp(g, a[order], ratio[order])
    return r


def filter_ratio(params, mode: int, f_hz: float, dt: float) -> tuple[complex, complex]:
    """(U_other, U_mode) [s]: the paper's observer as a linear filter (friction off) from the measured
    tip velocity to u_rel_hat = C_u z_k|k at f_hz [Hz], per unit input, split into the other modes'
    part and the part of ``mode`` (1-based), whose rows the participation scales:

        z_k|k-1 = (zeta I - A_d (I - M C_meas))^-1 A_d M Y,   z_k|k = z_k|k-1 + M (Y - C_meas z_k|k-1),
        zeta = exp(i 2 pi f dt)"""
    n = len(params.M)
    N = n // 2
    zeta = np.exp(2j * np.pi * f_hz * dt)
    z = np.linalg.solve(zeta * np.eye(n) - params.A_d @ (np.eye(n) - np.outer(params.M, params.C_meas)),
                        params.A_d @ params.M)
    z = z + params.M * (1.0 - params.C_meas @ z)
    rows = np.zeros(n, dtype=bool)
    rows[[mode - 1, N + mode - 1]] = True
    return complex(params.C_u[~rows] @ z[~rows]), complex(params.C_u[rows] @ z[rows])


def participation(params, dt: float, grid=AMP_GRID_M, ratios=None) -> np.ndarray:
    """(N, G) p_i(a_j) such that the observer as a linear filter (``filter_ratio``) has the plant's
    |U_rel / V_meas| at each point (f, U, rho) of ``ratios`` (``PLANT_RATIOS``), at that point's
    frequency f:

        |U_other(f) + p U_mode(f)| = rho          (the positive root)

    piecewise linear in the kernel's amplitude coordinate and held beyond the first and last points;
    1 for a mode without points. The kernel's a_i is mode i's share of u_rel before the factor
    (``scale`` = |t phi_i|), so a point (f, U, rho) sits at a = U / p."""
    ratios = PLANT_RATIOS if ratios is None else ratios
    n = len(params.M)
    g = np.asarray(grid, dtype=float)
    p = np.ones((n // 2, len(g)))
    for mode, pts in ratios.items():
        if mode > n // 2 or not pts:
            continue
        a, fac = [], []
        for f_hz, U, rho in sorted(pts, key=lambda q: q[1]):
            U_o, U_m = filter_ratio(params, mode, f_hz, dt)
            b = (U_o * np.conj(U_m)).real / abs(U_m) ** 2
            fac.append(-b + np.sqrt(b * b + (rho ** 2 - abs(U_o) ** 2) / abs(U_m) ** 2))
            a.append(U / fac[-1])
        if np.any(np.diff(a) <= 0.0):
            raise ValueError(f"participation of mode {mode}: the points' amplitudes U / p {a} [m] do not "
                             "increase with U; give points whose U / p increases")
        p[mode - 1] = np.interp(g, a, fac)
    return p


def schedule_ratios(cfg: Config) -> dict[int, tuple[tuple[float, float, float], ...]]:
    """The participation's points for the configuration: ``PLANT_RATIOS`` where its plant is the
    default's (``frictionrt.observer.amplitude_schedule.plant_key``), else none (p = 1: the ratio is
    measured on the default plant only)."""
    from frictionrt.observer.amplitude_schedule import plant_key
    from frictionrt.rt.common.config import load
    return PLANT_RATIOS if plant_key(cfg) == plant_key(load()) else {}


def schedule_peaks(cfg: Config, plant=None) -> dict[int, tuple[tuple[float, float], ...]]:
    """The schedule's points for the configuration: ``PLANT_PEAKS`` (the measured step-sine table)
    where its plant is the default's (``frictionrt.observer.amplitude_schedule.plant_key``), else
    the points computed from its own plant by harmonic balance
    (``frictionrt.observer.amplitude_schedule.harmonic_peaks``; costly the first time, then cached)."""
    from frictionrt.observer.amplitude_schedule import harmonic_peaks, plant_key
    from frictionrt.rt.common.config import load
    if plant_key(cfg) == plant_key(load()):
        return PLANT_PEAKS
    return harmonic_peaks(cfg, plant)


def mode_blocks(omega: float, zeta: float, b: float, dt: float) -> np.ndarray:
    """(6,) exact ZOH of one mode, A = [[0, 1], [-omega^2, -2 zeta omega]], input column [0, b],
    over dt [s] (module docstring): Ad row-major, then bd."""
    aug = np.zeros((3, 3))
    aug[0, 1] = 1.0
    aug[1, 0] = -omega * omega
    aug[1, 1] = -2.0 * zeta * omega
    aug[1, 2] = b
    E = sla.expm(aug * dt)
    return np.array([E[0, 0], E[0, 1], E[1, 0], E[1, 1], E[0, 2], E[1, 2]])


def rebased_peaks(peaks, reference_hz, model_hz) -> dict[int, tuple[tuple[float, float], ...]]:
    """The schedule's points (a, r = peak / reference) re-expressed over another model's frequencies:
    (a, r reference_hz[i] / model_hz[i]) for mode i + 1, so that the scheduled frequency r omega_i is the
    same peak."""
    return {m: tuple((a, r * float(reference_hz[m - 1]) / float(model_hz[m - 1])) for a, r in pts)
            for m, pts in peaks.items()}


def design_amplitude(cfg: Config, plant=None, peaks=None, jenkins: bool = False,
                     spring_scale: float | None = None, ratios=None) -> tuple[ObserverDesign, AmplitudeParams]:
    """The paper's design (its gain, its outputs) and the amplitude-following blocks (module
    docstring). ``peaks``: the schedule's points (default ``schedule_peaks``: the measured table on
    the default plant, harmonic balance on another). ``jenkins``:
    the joint as a Jenkins element (``joint_stiffness`` in series with the slider mu F_N) instead
    of the regularised Coulomb force, its stuck linearisation checked for stability too.
    ``spring_scale``: the model's normal springs under the adaptive screw at that share of k_n_area
    (``frictionrt.observer.model.build_observer_model``; None: ``cfg.observer.spring_scale``; 1: the
    paper's model), the schedule's points
    re-based onto that model's frequencies (``rebased_peaks``; they are stated over the plant's
    sliding-joint linearisation at F_min). ``ratios``: the participation's points (``participation``;
    default ``schedule_ratios``: ``PLANT_RATIOS`` on the default plant, none on another), folded into
    bd at design time (the friction's generalised force on mode i is -p_i t phi_i f_r).

    Raises ValueError if the error dynamics with the paper's gain are unstable at a grid amplitude
    (every mode at its r_i(a_j)), as ``design_observer`` does for its own model."""
    spring_scale = cfg.observer.spring_scale if spring_scale is None else float(spring_scale)
    design = design_observer(cfg, plant, spring_scale)
    peaks = schedule_peaks(cfg, plant) if peaks is None else peaks
    model = design.model
    if spring_scale != 1.0:
        from frictionrt.plant.model import build_plant
        from frictionrt.plant.modes import sliding_joint_hz
        peaks = rebased_peaks(peaks, sliding_joint_hz(build_plant(cfg) if plant is None else plant,
                                                       cfg.tracking.F_min_N), model.modes_hz)
    p = design.params
    N = len(model.omega)
    dt = cfg.dt_s
    tphi = model.C_v[N:]
    r = frequency_ratios(N, AMP_GRID_M, peaks)
    part = participation(p, dt, AMP_GRID_M, schedule_ratios(cfg) if ratios is None else ratios)
    G = len(AMP_GRID_M)
    blocks = np.empty((N, G, 7))
    for i in range(N):
        for j in range(G):
            blocks[i, j, :6] = mode_blocks(r[i, j] * model.omega[i], model.zeta, -part[i, j] * tphi[i], dt)
            blocks[i, j, 6] = part[i, j]
    n = 2 * N
    I_MC = np.eye(n) - np.outer(p.M, p.C_meas)
    k_j = joint_stiffness(cfg, model) if jenkins else 0.0
    for j in range(G):
        A_d = np.zeros((n, n))
        bd = np.zeros(n)
        for i in range(N):
            A_d[np.ix_([i, N + i], [i, N + i])] = blocks[i, j, :4].reshape(2, 2)
            bd[[i, N + i]] = blocks[i, j, 4:6]
        T = A_d @ I_MC
        if jenkins:  # stuck: f = k_eff C_u A_d z (the slider fixed), k_eff = k_j / (1 - k_j (C_u bd + D_u))
            C_u = model.C_u * np.tile(part[:, j], 2)
            k_eff = k_j / (1.0 - k_j * (C_u @ bd + model.D_u))
            T = (np.eye(n) + k_eff * np.outer(bd, C_u)) @ T
        rho = float(np.max(np.abs(np.linalg.eigvals(T))))
        if rho >= 1.0:
            raise ValueError(f"amplitude observer: unstable with the paper's gain at {AMP_GRID_M[j]:g} m "
                             f"(max |eig| = {rho:.6f}); check the schedule's peaks")
    params = AmplitudeParams(np.asarray(AMP_GRID_M, dtype=float), blocks, np.abs(tphi).copy(), 1.0 / model.omega,
                             k_j)
    for a in params:
        if isinstance(a, np.ndarray):
            a.setflags(write=False)
    return design, params
