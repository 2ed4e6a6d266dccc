"""The shaker stage of the loop (docs/loop.md, "The shaker"): an electrodynamic shaker is not an
ideal force source. Between the excitation generator and the plant:

    drive (the generator's signal) -> coil force F_coil = drive [N]
    armature:  m_a x_a'' + c_a x_a' + k_a x_a = F_coil - F_exc
    stinger:   F_exc = k_s (x_a - w_exc) + c_s (x_a' - w_exc')      (the force transducer at its tip)

w_exc [m] is the structure's displacement at the excitation point (``plant.excitation_point``),
x_a [m] the armature's, both from rest; F_exc pushes the structure in +w. ``armature_mass_kg`` = 0
(the default) is the ideal source F_exc = drive: the stage is not run (``Shaker.on``).

Coupling: over tick k the plant holds one force, so the stage gives it the mean stinger force over
[t_k, t_k+1]. The structure's motion over the tick is extrapolated from its state at t_k,
w(t_k + s) = w_k + v_k s (the plant's outputs w_exc, v_exc at t_k): the structure responds to
this tick's force one tick late (explicit coupling). With that input the armature's linear ODE is
integrated exactly (matrix exponential of the system augmented by drive, w, w' and the force's
integral, ``build_shaker``), so one tick is a 3 x 5 matrix-vector product (``_shaker_step``).

Stability (``coupled_spectral_radius``): a one-tick lag on a stiff spring feeds energy in, as a
negative damping of about k_s dt / 2 at the stinger mode for a zero-order lag, much less with the
linear extrapolation. At design time the coupled linear map (the stuck plant's exact one-tick map
of ``frictionrt.plant.linear_frf.discrete_map``, the stage, the lag) is formed and its spectral radius
checked: ``build_shaker`` refuses a shaker whose coupled loop would not be stable with a margin.

Defaults (``frictionrt.rt.common.config.Shaker``, a small modal shaker, 45-100 N class): flexure resonance 20 Hz,
5 % damping (k_a = m (2 pi 20 Hz)^2: 1.6e3 N/m at 0.1 kg; given as a frequency, so that the whole
shaker vanishes continuously as m -> 0: the ratio below -> 1 / (1 + 0) ); stinger 5e6 N/m (a 2 mm
steel rod, ~130 mm long: E A / L = 210e9 * 3.14e-6 / 0.13) and 20 N s/m (~1.4 % of critical at
0.1 kg: armature-on-stinger resonance ~1.1 kHz, 1.2 kHz coupled to the beam).

Closed form (``force_ratio``): for a harmonic drive at omega, with the driving-point receptance
R = w_exc / F_exc of the structure,

    drive / F_exc = 1 + D_a / k~ + D_a R,    D_a = k_a + i omega c_a - m_a omega^2,  k~ = k_s + i omega c_s,
    (plant.shaker.suspension: k_a, c_a proportional to m_a)

so F_exc / drive drops where |R| is large (the structure's resonances: force drop-out) and rises
near the zero of D_a (1 + D_a / k~) + D_a R (the armature on the stinger against the structure).

The electrical port (``shaker.amplifier``): the coil, resistance R (coil, amplifier output and
cable), inductance L and force constant Bl, gives F_coil = Bl i and the back-EMF Bl x_a':

    L i' + R i + Bl x_a' = V.

In current mode (the default, and everything above) the amplifier forces i = drive / Bl whatever
the coil's voltage: F_coil = drive. In voltage mode it forces V = (R / Bl) drive (its gain set so
that the blocked coil's force at DC is the drive: a force scale [N/V] of the amplifier's volts is
then s = g_V Bl / R), and in the frequency domain, Z_e = R + i omega L,

    F_coil = (R / Z_e) drive - i omega (Bl^2 / Z_e) x_a,

so the armature's dynamic stiffness gains the back-EMF damping c_e = Bl^2 / R below the electrical
corner R / (2 pi L), and the force per drive becomes

    F_exc / drive = (R / Z_e) / (1 + D_e / k~ + D_e R),    D_e = D_a + i omega Bl^2 / Z_e.

With a stiff stinger the structure sees, at the drive point, the armature's mass, its flexure and
c_a + c_e (``drive_point_stiffness``): voltage drive damps the modes that move the drive point.
The current-drive limit is Z_e -> infinity at fixed drive current (R -> infinity with V = R i):
D_e -> D_a, R / Z_e -> 1 (tests/test_shaker_two_port.py shows it). Reference: McConnell and Varoto,
"Vibration Testing: Theory and Practice", 2nd ed. (Wiley 2008), the electrodynamic exciter's model
and its interaction with the structure; Varoto and de Oliveira, "Interaction between a vibration
exciter and the structure under test", Sound and Vibration 36(10), 2002.

Catalogue-typical defaults (``frictionrt.rt.common.config.Shaker``, a small modal shaker of the
100 N class: representative of the class, not one model's datasheet; Bl estimated as rated force /
rated current, 45-100 N at a few to ten amperes): R = 1.5 ohm (0.5-4), L = 0.3 mH (0.1-1),
Bl = 10 N/A (5-30): c_e = 67 N s/m, corner 800 Hz. Only the frequency domain has voltage
mode (``force_ratio``, ``harmonic_response``); the loop's time-domain stage models current mode
and ``check_shaker`` refuses voltage mode there.
"""
from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np

from frictionrt.rt.common.config import Config

N_IN = 5  # x_a, x_a', drive, w_exc, w_exc' at t_k


class ShakerParams(NamedTuple):
    """Constants of ``_shaker_step`` (``build_shaker``)."""
    P: np.ndarray   # (3, N_IN): rows x_a(t_k+1), x_a'(t_k+1), mean F_exc over the tick, per input


def continuous_matrices(cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """(A, B) of the armature, state [x_a, x_a'], input [drive, w_exc, w_exc']; the stinger force is
    F_exc = [k_s, c_s] x + [0, -k_s, -c_s] u. Requires armature_mass_kg > 0."""
    s = cfg.shaker
    m, ks, cs = s.armature_mass_kg, s.stinger_N_per_m, s.stinger_damping_Ns_per_m
    ka, ca = suspension(cfg)
    A = np.array([[0.0, 1.0], [-(ka + ks) / m, -(ca + cs) / m]])
    B = np.array([[0.0, 0.0, 0.0], [1.0 / m, ks / m, cs / m]])
    return A, B


def suspension(cfg: Config) -> tuple[float, float]:
    """(k_a [N/m], c_a [N s/m]) of the armature's flexure: k_a = m w_a^2, c_a = 2 zeta_a m w_a,
    w_a = 2 pi shaker.suspension_hz (a shaker is specified by its flexure resonance, so that the
    whole shaker vanishes continuously as m -> 0)."""
    s = cfg.shaker
    w_a = 2 * np.pi * s.suspension_hz
    return s.armature_mass_kg * w_a * w_a, 2.0 * s.suspension_zeta * s.armature_mass_kg * w_a


def build_shaker(cfg: Config) -> ShakerParams:
    """The exact one-tick map of the armature with the drive held and the structure's motion
    extrapolated linearly (module docstring). Augmented state z = [x_a, x_a', drive, w, w', I],
    I = integral of F_exc over the tick from 0:

        z' = M z,  z(dt) = expm(M dt) z(0);  rows of P: x_a(dt), x_a'(dt), I(dt) / dt.

    With the shaker off (``cfg.shaker.on`` false) P is zero (the loop does not call the stage)."""
    import scipy.linalg as sla
    P = np.zeros((3, N_IN))
    if not cfg.shaker.on:
        return ShakerParams(P)
    s = cfg.shaker
    A, B = continuous_matrices(cfg)
    M = np.zeros((6, 6))
    M[:2, :2] = A
    M[:2, 2:5] = B
    M[3, 4] = 1.0                                          # w' = w'_k (held slope)
    M[5, :5] = [s.stinger_N_per_m, s.stinger_damping_Ns_per_m, 0.0, -s.stinger_N_per_m,
                -s.stinger_damping_Ns_per_m]               # I' = F_exc
    dt = cfg.dt_s
    E = sla.expm(M * dt)
    P[0] = E[0, :5]
    P[1] = E[1, :5]
    P[2] = E[5, :5] / dt
    return ShakerParams(np.ascontiguousarray(P))


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _shaker_step(k, x, u, p, x_next, y):
    """Tick k of the shaker: x = [x_a, x_a'] at t_k, u = [drive [N], w_exc [m], w_exc' [m/s]] at
    t_k; x_next = the state at t_k+1, y[0] = F_exc [N], the mean stinger force over the tick (what
    the plant holds and the force transducer reads). RT-safe: 15 multiply-adds."""
    P = p.P
    for i in range(3):
        acc = P[i, 0] * x[0] + P[i, 1] * x[1] + P[i, 2] * u[0] + P[i, 3] * u[1] + P[i, 4] * u[2]
        if i < 2:
            x_next[i] = acc
        else:
            y[0] = acc


def electrical_impedance(cfg: Config, w) -> np.ndarray:
    """Z_e = R + i omega L [ohm] of the coil at angular frequencies w [rad/s]."""
    s = cfg.shaker
    return s.coil_resistance_ohm + 1j * np.asarray(w, float) * s.coil_inductance_H


def armature_stiffness(cfg: Config, w) -> np.ndarray:
    """The armature's dynamic stiffness [N/m] (complex) at w [rad/s]: D_a = k_a + i omega c_a - m_a omega^2,
    plus the back-EMF term i omega Bl^2 / Z_e in voltage mode (module docstring)."""
    s = cfg.shaker
    w = np.asarray(w, float)
    k_a, c_a = suspension(cfg)
    D = k_a + 1j * w * c_a - s.armature_mass_kg * w * w
    if s.amplifier == "voltage":
        D = D + 1j * w * s.force_constant_N_per_A ** 2 / electrical_impedance(cfg, w)
    return D


def coil_gain(cfg: Config, w) -> np.ndarray:
    """F_coil / drive [-] of the blocked armature (x_a = 0) at w [rad/s]: 1 in current mode, R / Z_e in
    voltage mode (the coil's electrical pole at R / L)."""
    w = np.asarray(w, float)
    if cfg.shaker.amplifier == "voltage":
        return cfg.shaker.coil_resistance_ohm / electrical_impedance(cfg, w)
    return np.ones(w.shape, complex)


def force_ratio(cfg: Config, freq_hz, R) -> np.ndarray:
    """F_exc / drive [-] (complex) of the shaker on a structure with driving-point receptance
    R [m/N] (complex, per frequency) at freq_hz [Hz] (module docstring), in the amplifier's mode;
    1 with the shaker off."""
    f = np.atleast_1d(np.asarray(freq_hz, float))
    R = np.broadcast_to(np.asarray(R, complex), f.shape)
    s = cfg.shaker
    if not s.on:
        return np.ones(f.shape, complex)
    w = 2 * np.pi * f
    k_s = s.stinger_N_per_m + 1j * w * s.stinger_damping_Ns_per_m
    if s.amplifier == "voltage":
        D_e = armature_stiffness(cfg, w)
        return coil_gain(cfg, w) / (1.0 + D_e / k_s + D_e * R)
    k_a, c_a = suspension(cfg)
    D_a = k_a + 1j * w * c_a - s.armature_mass_kg * w * w
    return 1.0 / (1.0 + D_a / k_s + D_a * R)


def drive_point_stiffness(cfg: Config, freq_hz) -> np.ndarray:
    """The dynamic stiffness K_sh = -F_exc / w_exc [N/m] (complex) that the shaker with its drive at 0
    adds at the structure's drive point, at freq_hz [Hz]: stinger and armature in series,
    1 / K_sh = 1 / k~ + 1 / D_e (module docstring); its mechanical impedance is K_sh / (i omega).
    0 with the shaker off."""
    f = np.atleast_1d(np.asarray(freq_hz, float))
    s = cfg.shaker
    if not s.on:
        return np.zeros(f.shape, complex)
    w = 2 * np.pi * f
    k_s = s.stinger_N_per_m + 1j * w * s.stinger_damping_Ns_per_m
    return 1.0 / (1.0 / k_s + 1.0 / armature_stiffness(cfg, w))


class HarmonicResponse(NamedTuple):
    """Complex amplitudes of the shaker on a structure, per frequency: coil voltage V [V], current i [A],
    armature x_a [m], drive point w [m], coil force F_coil = Bl i [N], stinger force F_exc [N]."""
    V: np.ndarray
    i: np.ndarray
    x_a: np.ndarray
    w: np.ndarray
    F_coil: np.ndarray
    F_exc: np.ndarray


def harmonic_response(cfg: Config, freq_hz, R, drive: float = 1.0) -> HarmonicResponse:
    """The steady state of the shaker (on) driving a structure of driving-point receptance R [m/N]
    at freq_hz [Hz] with a harmonic drive of amplitude ``drive`` [N, the blocked coil's force at DC]:
    F_exc = drive x ``force_ratio``, w = R F_exc, x_a = w + F_exc / k~, and the coil's port
    (current mode: i = drive / Bl, V = Z_e i + Bl i omega x_a; voltage mode: V = R drive / Bl,
    i = (V - Bl i omega x_a) / Z_e)."""
    f = np.atleast_1d(np.asarray(freq_hz, float))
    R = np.broadcast_to(np.asarray(R, complex), f.shape)
    s = cfg.shaker
    w = 2 * np.pi * f
    Bl = s.force_constant_N_per_A
    k_s = s.stinger_N_per_m + 1j * w * s.stinger_damping_Ns_per_m
    F_exc = drive * force_ratio(cfg, f, R)
    w_exc = R * F_exc
    x_a = w_exc + F_exc / k_s
    Z_e = electrical_impedance(cfg, w)
    if s.amplifier == "voltage":
        V = np.full(f.shape, s.coil_resistance_ohm * drive / Bl, complex)
        i = (V - Bl * 1j * w * x_a) / Z_e
    else:
        i = np.full(f.shape, drive / Bl, complex)
        V = Z_e * i + Bl * 1j * w * x_a
    return HarmonicResponse(V, i, x_a, w_exc, Bl * i, F_exc)


def coupled_spectral_radius(cfg: Config, model=None, F_N1: float | None = None) -> float:
    """Spectral radius of the loop's linear one-tick map with the shaker coupled as the loop couples
    it, on the plant linearised stuck at F_N1 [N] (``frictionrt.plant.linear_frf.stuck_model`` at the
    excitation point): the plant's exact tick map s' = Phi s + Gam F (s = [q, q'] modal), the
    shaker's P on [x_a, x_a', 0, r.q, r.q'] of t_k. < 1: the coupled loop is stable (the linear
    part; the contact's slip only adds dissipation). 0 with the shaker off."""
    if not cfg.shaker.on:
        return 0.0
    from frictionrt.plant.linear_frf import discrete_map, stuck_model
    from frictionrt.plant.model import build_plant
    model = build_plant(cfg) if model is None else model
    lin = stuck_model(model, cfg.plant.excitation_point, F_N1)
    Phi, Gam = discrete_map(lin, cfg.dt_s, cfg.plant.substeps)
    n = len(lin.b)
    P = build_shaker(cfg).P
    # F_k = P2 . [x_a, v_a, 0, r q_k, r q'_k];  state [q, q', x_a, v_a]
    row_F = np.concatenate([P[2, 3] * lin.r, P[2, 4] * lin.r, P[2, :2]])
    T = np.zeros((2 * n + 2, 2 * n + 2))
    T[:2 * n, :2 * n] = Phi
    T[:2 * n] += np.outer(Gam, row_F)
    T[2 * n:, :2 * n] = np.outer(P[:2, 3], np.concatenate([lin.r, np.zeros(n)])) + \
        np.outer(P[:2, 4], np.concatenate([np.zeros(n), lin.r]))
    T[2 * n:, 2 * n:] = P[:2, :2]
    return float(np.max(np.abs(np.linalg.eigvals(T))))


def check_shaker(cfg: Config, model=None) -> None:
    """ValueError naming the stinger if the loop with this shaker would be unstable (spectral
    radius of ``coupled_spectral_radius`` >= 1, on the plant stuck at its initial F_N1), or naming
    the amplifier in voltage mode (the stage is current mode's); nothing with the shaker off. The defaults leave every eigenvalue's damping at or above the plant's own
    (docs/loop.md); a stinger of 5e7 N/m at 0.1 kg is refused."""
    if not cfg.shaker.on:
        return
    if cfg.shaker.amplifier != "current":
        raise ValueError(f"shaker.amplifier = {cfg.shaker.amplifier!r}: the loop's shaker stage models a current-driven "
                         "shaker only; use shaker.amplifier=current, or shaker.armature_mass_kg=0 for an ideal force "
                         "source (voltage mode is in the frequency domain: the rig's and the diagnosis' FRF files "
                         "per drive volt)")
    rho = coupled_spectral_radius(cfg, model)
    if not rho < 1.0:
        raise ValueError(f"shaker.stinger_N_per_m = {cfg.shaker.stinger_N_per_m:g} N/m: the loop's one-tick "
                         f"coupling of this shaker to the plant is unstable (spectral radius {rho:.6f} >= 1); "
                         "use a softer stinger, more stinger damping, or a higher rt.rate_hz")
