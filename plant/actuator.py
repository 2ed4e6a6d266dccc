"""Actuator chain from the DAC command to the adaptive screw force F_N1 (SPEC section 3).

    V_cmd --DAC (16 bit, ZOH)--> V_dac --30 kHz Butterworth (analog)--> v_f
          --amplifier (first order, slew = I_max/C, rails)--> V_a --piezo stack + screw--> F_N1
          --strain gauge / piezo force cell (analog first-order)--> F_strain_a, F_cell_a

Continuous-time model (state s = [v_f, r, V_a, x, x', F_strain_a, F_cell_a],
r = (dv_f/dt)/w_lp [V]):

    v_f' = w_lp r                                         2nd-order Butterworth, w_lp = 2 pi lowpass_hz
    r'   = w_lp (V_dac - v_f) - sqrt(2) w_lp r            (v_f/V_dac = w^2 / (s^2 + sqrt(2) w s + w^2))
    V_a' = w_a (v_f - V_a),  |V_a'| <= I_max / C,  V_min <= V_a <= V_max
    m x'' + c x' + (k_stack + k_screw) x = k_stack d V_a
    F_N1 = F0 + k_screw x
    F_strain_a' = w_s (F_N1 - F_strain_a),  F_cell_a' = w_c (F_N1 - F_cell_a)

    w_a = 2 pi amp_bandwidth_hz;  c = 2 zeta_stack sqrt((k_stack + k_screw) m);
    d = c_v (k_stack + k_screw) / (k_stack k_screw)  [m/V]  so that statically F_N1 = F0 + c_v V_a.

The stack (stiffness k_stack, free elongation d V_a) and the screw (k_screw) act in series on
the moving mass m; x is the screw's elongation from its preload F0. One-way coupling: the
structure's vibration does not act back on the stack (the screw head is taken as fixed).
F_N1 is not limited at 0: a full-range slew rings the stack (zeta = 0.05) ~50 N beyond its
end values, e.g. down to -17 N after 150 -> 0 V, where the real screw would lift off.

Piezo hysteresis (actuator.hysteresis_width_rel > 0; off by default). The stack's free
elongation is d (V_a - h), h [V] a Bouc-Wen state (n = 1, gamma = 0, i.e. Dahl's form, which
Low & Guo 1995 and Goldfarb & Celanovic 1997 use for stacks):

    h' = A V_a' - beta |V_a'| h,   so that quasi-statically F_N1 = F0 + c_v (V_a - h),

rate independent (dh/dV_a depends on the direction only); h saturates at +-A / beta,
beta = 2 / (V_max - V_min) (``HYST_BETA_RANGE``), and A is set by the loop width
(``hysteresis_constants``). One substep's change is exact for a monotone V_a (``_hysteresis``);
h enters the stack as an input held first-order over the substep (the m update's Gm0, Gm1).
Structure and impulse tests at constant V_a are unchanged (h = 0 from rest).

Preload creep (actuator.creep_per_decade = c > 0; off by default). After a step of the stack's
force the screw thread creeps and F_N1 relaxes by c of the step per decade of time,
F_step (1 - c log10(1 + t / tau0)). One first-order state per decade, a Prony series
(tau_j = tau0 10^j, j = 0..K-1, tau0 = ``CREEP_TAU0_S`` = 1 ms, K = ``CREEP_DECADES`` = 5):

    q_j' = (g_j u - q_j) / tau_j,   u = V_a - h,   stack input (1 + G) u - sum_j q_j  instead of u,
    g_j = c w_j / (1 - c W),  G = sum_j g_j,  W = sum_j w_j

so that at rest (q_j = g_j u) the input is u and c_v stays the static gain, and after a step du
the input is u0 + (1 + G) du (1 - c sum_j w_j (1 - e^{-t / tau_j})): F_step = c_v (1 + G) du, and
sum_j w_j (1 - e^{-t / tau_j}) is within 0.024 decade of log10(1 + t / tau0) over [0, 10 s]
(``creep_weights``: least-squares weights; equal ones would be 0.75 decade off). The q_j are
states of the LTI chain, so the linear, slewing and held updates stay exact: the matrices come
from the system augmented by q_j (``creep_ss``), the extra rows and columns in ``Q``
(``ActuatorParams``); ``initial_state`` puts q_j at rest for the initial V (a bolt held there for
long), so runs at constant V stay at rest. c = 0 builds the 7-state chain: runs are bit-identical.

The bolt force sensors' analog parts (w_s = 2 pi sensors.strain_bandwidth_hz, w_c = 2 pi
sensors.cell_bandwidth_hz) are integrated here, with the stack, because F_N1(t) is only known
inside this continuous integration: filtering the 21 kHz samples of F_N1 afterwards (as
plant.sensors does when given F_N1) misses the stack's 7.1 kHz ringing between samples (0.6-0.7 N
rms error on a 230 Hz bang-bang command through a 1 kHz setpoint filter, against a 0.05 N cell
noise). plant.sensors adds noise and the ADC to F_strain_a and F_cell_a.

Discretisation (design time, exact). The 30 kHz corner lies above the controller's Nyquist
frequency (10.5 kHz), so the filter is never a discrete 21 kHz filter: the whole chain is
integrated in continuous time over n_sub substeps of h = dt / n_sub per controller step, in the
amplifier's regime at the substep's start and end (L = I_max / C the slew rate, s = w_a (v_f - V_a)
the slope the linear amplifier would take):

  * linear (|s| <= L at both ends, V_a inside the rails): the 7-state system above is LTI with
    V_dac held (the DAC's zero-order hold), one substep is  s1 = Ad s0 + Bd V_dac  with [Ad, Bd]
    from the matrix exponential: exact;
  * slewing (|s| > L at both ends, same sign, inside the rails): V_a1 = V_a0 +- L h, a ramp; the
    filter keeps its exact update (the amplifier does not load it) and the stack with the force
    sensors, m = [x, x', F_strain_a - F0, F_cell_a - F0], takes the exact first-order-hold update
    m1 = Pm m0 + Gm0 V_a0 + Gm1 (V_a1 - V_a0): exact;
  * held at a rail (V_a0 at V_max or V_min and s pushing outwards at both ends): the same with
    V_a1 = V_a0: exact;
  * a substep in which the regime changes (entering or leaving the slew limit, reaching a rail)
    is recomputed as N_FINE substeps of h / N_FINE, each taking the linear update with its change
    clipped to +-L h / N_FINE and to the rails (stack by the ramp update if clipped).

So the only approximation is the instant at which the amplifier changes regime, resolved to
h / N_FINE = dt / (n_sub N_FINE). (The regime is judged at the substep's ends: a slope that
crossed L only inside a substep would go unseen, but s varies on the 8 us amplifier and 33 us
low-pass time scales, slower than h = 5.95 us.)

Signals: i = C (V_a1 - V_a0) / h, the amplifier's mean current over the last substep [A]
(equal to +-I_max while slewing); P = i (V_a0 + V_a1) / 2, the mean power over that substep [W];
E = integral |V_a i| dt [J], accumulated per substep as C/2 |V_a1^2 - V_a0^2| (or
C/2 (V_a0^2 + V_a1^2) if V_a changes sign), which is exact while V_a is monotone within a
substep. |P| and not P: the amplifier is linear (not regenerative), so the charge it pulls back
out of the stack is burnt in its output stage instead of recovered; integral P dt would only be
the change of the stored energy C V_a^2 / 2 and vanish over a cycle, hiding the control effort
(SPEC claim C6 compares the actuator power of the two laws).

Length: the actuator chain (DAC, low-pass, amplifier, piezo stack with hysteresis and creep,
the bolt force sensors) is one compiled step over one state vector, with its design and its
equations' derivations in the docstrings; each stage is a short inlined kernel here.
"""
from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numba
import numpy as np
import scipy.linalg as sla

from frictionrt.rt.common.config import Config

# Substeps per controller step and fine substeps per regime change (module docstring). The
# linear, slewing and held regimes are exact at any n_sub; n_sub and N_FINE set how finely the
# instant of a regime change is resolved: dt / 64 = 0.74 us with 8 x 8. Measured against a
# DOP853 integration of the continuous model (rtol 1e-12, docs/actuator_sensors.md): F_N1 of a
# 0 -> 150 V -> 0 command within 1.9e-5 of its 657 N swing (8 x 1, no refinement: 5.4e-3,
# because the amplifier starts to slew ~1 us after the step, inside the first 5.95 us substep),
# a 4.5 kHz sine that slews at every peak within 2.3e-4 (8 x 1: 4.4e-2). Cost ~5 ns per
# substep: the actuator step takes ~90 ns.
N_SUB = 8
N_FINE = 8

CREEP_DECADES = 5
"""K, the creep states q_0..q_{K-1} (one per decade of time, module docstring "Preload creep"):
tau_j = CREEP_TAU0_S 10^j spans 1 ms to 10 s, so the log law holds from the rig's 40 ms holds to a
loop run of seconds; beyond ~10 tau_{K-1} = 100 s the series has relaxed fully (c_v, the static
gain). Each state costs ~12 multiply-adds per substep."""
CREEP_TAU0_S = 1e-3
"""tau0 [s] of the log law F_step (1 - c log10(1 + t / tau0)): below it the relaxation is linear
in t. 1 ms = 21 controller ticks, the shortest time at which the rig sees the drift apart from
the stack's ringing (7.1 kHz, zeta 0.05: decays by e within 0.45 ms)."""

ACTUATOR_SLOTS = ("v_f", "r", "V_a", "x", "x_dot", "F_strain_a", "F_cell_a", "E", "h") + tuple(
    f"q_{j}" for j in range(CREEP_DECADES))
"""State slots: filter output v_f [V], filter rate r = (dv_f/dt)/w_lp [V], amplifier output
V_a [V], screw elongation x [m] and its rate x' [m/s], analog strain-gauge and force-cell
outputs [N], delivered energy E [J], piezo hysteresis state h [V] (0 without hysteresis),
creep states q_0..q_{K-1} [V] (0 without creep)."""

ACTUATOR_OUTPUTS = (("F_stack", "N"), ("V_dac", "V"), ("v_f", "V"), ("V_a", "V"),
                    ("i", "A"), ("P", "W"), ("E", "J"), ("F_strain_a", "N"), ("F_cell_a", "N"))
"""Output slots (name, unit) of ``_actuator_step``'s y, values at t_{k+1} (F_stack: the adaptive
screw's force F0 + k_screw x with the beams' separation at zero, the input of the plant's bolt,
which adds k (g - g_ref): plant output F_N1, docs/plant.md 1.4; V_dac: held over
[t_k, t_{k+1}); i, P: means over the last substep; F_strain_a, F_cell_a: the force sensors'
analog outputs, before their noise and ADC in ``frictionrt.plant.sensors``)."""

N_STATE = 7  # continuous states without creep (all slots but E, h, q_j)
Q0 = 9       # slot of q_0


class ActuatorParams(NamedTuple):
    """Constant arrays of the actuator step (built by ``build_actuator``).

    M and M_f hold the exact discretisations over h and h_f = h / n_fine (``discretise``),
    one block matrix each (one array instead of five keeps the kernel's argument small):

                 v_f r V_a x x' z_s z_c  V_dac   x x' z_s z_c   V_a0  dV_a
        M  =  [                        |      |             |     |     ]  v_f
              [                        |      |      0      |  0  |  0  ]  r
              [                        |      |             |     |     ]  V_a
              [       Ad (7 x 7)       |  Bd  |             |     |     ]  x
              [                        |      |     Pm      | Gm0 | Gm1 ]  x'
              [                        |      |   (4 x 4)   |     |     ]  z_s
              [                        |      |             |     |     ]  z_c   (7 x 14)

    z_s = F_strain_a - F0, z_c = F_cell_a - F0 (deviations: the model is then homogeneous in
    V). Linear: s1 = Ad s0 + Bd V_dac; amplifier clipped (ramp V_a0 -> V_a0 + dV_a):
    [x, x', z_s, z_c]1 = Pm [x, x', z_s, z_c]0 + Gm0 V_a0 + Gm1 dV_a.

    With creep (n_creep = K > 0) the blocks are those of the system augmented by q_0..q_{K-1}
    (``creep_ss``) and Q holds the rest, row j for q_j:

              x x' z_s z_c     v_f  r  V_a  V_dac   e_j    G0_j  G1_j
        Q = [ response to q_j | q_j1, linear regime | e^{-h/tau_j} | ramp  ]   (K x 11)

    Both regimes: [x, x', z_s, z_c]1 += Q[j, 0:4] q_j0 (q_j is driven by V_a only); linear:
    q_j1 = Q[j, 4:8] . [v_f, r, V_a, V_dac]0 + e_j q_j0; ramp: q_j1 = e_j q_j0 + G0_j V_a0 + G1_j dV_a.
    """
    V_min: float      # amplifier / DAC range, low end [V]
    V_max: float      # high end [V]
    lsb: float        # DAC step (V_max - V_min) / (2^dac_bits - 1) [V]
    inv_lsb: float    # 1 / lsb [1/V]
    w_a: float        # amplifier bandwidth 2 pi amp_bandwidth_hz [rad/s]
    L: float          # slew rate I_max / C [V/s]
    C: float          # stack capacitance [F]
    n_sub: int        # substeps per controller step
    h: float          # substep [s]
    M: np.ndarray     # (7, 14) discretisation over h (layout above)
    n_fine: int       # fine substeps of a substep in which the amplifier changes regime
    h_f: float        # h / n_fine [s]
    M_f: np.ndarray   # (7, 14) discretisation over h_f
    F0: float         # F_N1 at x = 0 [N]
    k_screw: float    # [N/m]
    x_per_V: float    # static elongation per volt c_v / k_screw [m/V]
    hyst_A: float     # Bouc-Wen gain A of h' = A V_a' - beta |V_a'| h [-]; 0: no hysteresis
    hyst_beta: float  # Bouc-Wen beta [1/V] (``hysteresis_constants``)
    n_creep: int      # creep states in use: CREEP_DECADES, or 0 without creep
    creep_g: np.ndarray  # (n_creep,) static gains g_j of q_j = g_j (V_a - h) at rest [-]
    Q: np.ndarray     # (n_creep, 11) creep coefficients over h (``creep_block``)
    Q_f: np.ndarray   # (n_creep, 11) over h_f


# --- design time -----------------------------------------------------------------------------

def discretise(A: np.ndarray, B: np.ndarray, h: float, scale: np.ndarray | None = None):
    """Exact discretisation of x' = A x + B u over a step h for held and ramped inputs.

    Over [0, h] with u(t) = u0 + (u1 - u0) t / h (first-order hold; u1 = u0 is the zero-order
    hold):  x(h) = Phi x(0) + G0 u0 + G1 (u1 - u0),
        Phi = e^{A h},  G0 = int_0^h e^{A s} ds B,  G1 = (1/h) int_0^h e^{A (h - s)} s ds B,
    all read from one matrix exponential of the augmented system [x; u; u'] (Van Loan).

    ``scale`` (n,) optional: typical magnitudes of the states; the exponential is taken in
    coordinates x / 2^round(log2(scale)) (an exact similarity in floating point) so that states of
    very different sizes (volts and micrometres) do not lose relative accuracy.

    Returns (Phi (n, n), G0 (n, m), G1 (n, m)).
    """
    A = np.atleast_2d(np.asarray(A, float))
    B = np.asarray(B, float).reshape(A.shape[0], -1)
    n, m = B.shape
    s = np.ones(n) if scale is None else 2.0 ** np.round(np.log2(np.asarray(scale, float)))
    As = A * (1.0 / s)[:, None] * s[None, :]          # S^-1 A S
    Bs = B * (1.0 / s)[:, None]
    M = np.zeros((n + 2 * m, n + 2 * m))
    M[:n, :n] = As
    M[:n, n:n + m] = Bs
    M[n:n + m, n + m:] = np.eye(m)
    E = sla.expm(M * h)
    Phi = E[:n, :n] * s[:, None] * (1.0 / s)[None, :]  # S e^{A~ h} S^-1
    G0 = E[:n, n:n + m] * s[:, None]
    G1 = E[:n, n + m:] * s[:, None] / h
    return Phi, G0, G1


HYST_BETA_RANGE = 2.0
"""Bouc-Wen shape: beta (V_max - V_min); h saturates at A / beta over a voltage scale of half
the range (module docstring, "Piezo hysteresis")."""


def hysteresis_constants(cfg: Config) -> tuple[float, float]:
    """(A [-], beta [1/V]) of the Bouc-Wen hysteresis for actuator.hysteresis_width_rel = w.

    On a quasi-static triangle V_min -> V_max -> V_min from h = 0 the branches are
    h_up(V) = (A/beta)(1 - e^{-beta (V - V_min)}) and
    h_dn(V) = (h_up(V_max) + A/beta) e^{-beta (V_max - V)} - A/beta, so at mid range, with
    u = e^{-beta Vr / 2} (Vr = V_max - V_min), the force loop's width is
    c_v (h_up - h_dn) = c_v (A/beta) (1 - u)^2 (2 + u)  :=  w c_v Vr,
    i.e. A = w beta Vr / ((1 - u)^2 (2 + u)) (= 2.114 w at beta Vr = 2)."""
    a = cfg.actuator
    Vr = a.V_max - a.V_min
    beta = HYST_BETA_RANGE / Vr
    u = math.exp(-0.5 * HYST_BETA_RANGE)
    A = a.hysteresis_width_rel * HYST_BETA_RANGE / ((1.0 - u) ** 2 * (2.0 + u))
    return A, beta


@functools.lru_cache(maxsize=None)
def creep_weights() -> tuple[np.ndarray, np.ndarray]:
    """(tau (K,) [s], w (K,) [-]) of the Prony series of the log law: tau_j = tau0 10^j and the
    weights w_j with  sum_j w_j (1 - e^{-t / tau_j}) ~ log10(1 + t / tau0)  by least squares on
    4001 log-spaced t in [0, tau_{K-1}] (tau0 = CREEP_TAU0_S, K = CREEP_DECADES). Equal weights
    would leave an offset of 0.75 decade: the first weight carries the linear start (0.34), the
    last the tail beyond tau_{K-1} (1.23); measured, the fit is within 0.024 decade of the log
    law over [0, tau_{K-1}] (the ripple of a one-state-per-decade series)."""
    tau = CREEP_TAU0_S * 10.0 ** np.arange(CREEP_DECADES)
    t = np.concatenate([[0.0], np.logspace(math.log10(CREEP_TAU0_S) - 2.0, math.log10(tau[-1]), 4000)])
    w = np.linalg.lstsq(-np.expm1(-t[:, None] / tau[None, :]), np.log10(1.0 + t / CREEP_TAU0_S), rcond=None)[0]
    tau.setflags(write=False)
    w.setflags(write=False)
    return tau, w


def creep_constants(cfg: Config) -> tuple[np.ndarray, np.ndarray]:
    """(tau (K,) [s], g (K,) [-]) of the creep states for actuator.creep_per_decade = c (empty
    arrays for c = 0): g_j = c w_j / (1 - c W), W = sum_j w_j (``creep_weights``), so that after a
    step of u = V_a - h from rest the stack's input (1 + G) u - sum_j q_j (G = sum_j g_j) is
    u0 + du (1 + G) (1 - c sum_j w_j (1 - e^{-t / tau_j})): the instantaneous step (1 + G) du relaxes
    by c per decade, to du, c_v's static force (module docstring, "Preload creep")."""
    c = cfg.actuator.creep_per_decade
    if c == 0.0:
        return np.zeros(0), np.zeros(0)
    tau, w = creep_weights()
    return tau.copy(), c * w / (1.0 - c * float(np.sum(w)))


def stack_constants(cfg: Config) -> dict:
    """Derived piezo stack constants: K = k_stack + k_screw [N/m], c [N s/m], d [m/V],
    undamped stack frequency f_n [Hz] and its damped ringing frequency f_d [Hz]."""
    a = cfg.actuator
    K = a.k_stack + a.k_screw
    m = a.moving_mass_kg
    c = 2.0 * a.zeta_stack * math.sqrt(K * m)
    d = a.c_v * K / (a.k_stack * a.k_screw)
    wn = math.sqrt(K / m)
    return {"K": K, "c": c, "d": d, "m": m, "f_n": wn / (2 * math.pi),
            "f_d": wn * math.sqrt(1.0 - a.zeta_stack ** 2) / (2 * math.pi)}


def actuator_ss(cfg: Config):
    """Continuous linear model of the chain (amplifier limits ignored), for design (e.g. loop
    shaping on V_dac -> F_N1 or -> the force sensors).

    Returns (A (7, 7), B (7,), C (3, 7), F0) with  s' = A s + B V_dac  and
    (F_N1, F_strain_a, F_cell_a) = F0 + C s,  state s = [v_f, r, V_a, x, x', z_s, z_c] in SI
    units (z_s, z_c: the sensors' deviations from F0; module docstring).
    """
    a, se = cfg.actuator, cfg.sensors
    sc = stack_constants(cfg)
    w = 2.0 * math.pi * a.lowpass_hz
    wa = 2.0 * math.pi * a.amp_bandwidth_hz
    ws = 2.0 * math.pi * se.strain_bandwidth_hz
    wc = 2.0 * math.pi * se.cell_bandwidth_hz
    K, c, d, m, k = sc["K"], sc["c"], sc["d"], sc["m"], a.k_screw
    A = np.array([[0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0],
                  [-w, -math.sqrt(2.0) * w, 0.0, 0.0, 0.0, 0.0, 0.0],
                  [wa, 0.0, -wa, 0.0, 0.0, 0.0, 0.0],
                  [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
                  [0.0, 0.0, a.k_stack * d / m, -K / m, -c / m, 0.0, 0.0],
                  [0.0, 0.0, 0.0, ws * k, 0.0, -ws, 0.0],
                  [0.0, 0.0, 0.0, wc * k, 0.0, 0.0, -wc]])
    B = np.array([0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0])
    C = np.zeros((3, 7))
    C[0, 3] = k
    C[1, 5] = 1.0
    C[2, 6] = 1.0
    return A, B, C, a.F0_N


def creep_ss(cfg: Config):
    """``actuator_ss`` augmented by the creep states (state [v_f, r, V_a, x, x', z_s, z_c, q_0..]):
    q_j' = (g_j V_a - q_j) / tau_j and the stack's input (1 + G) V_a - sum_j q_j instead of V_a
    (``creep_constants``). Returns (A (7 + K, 7 + K), B (7 + K,)); K = 0 gives ``actuator_ss``'s."""
    A7, B7, _, _ = actuator_ss(cfg)
    tau, g = creep_constants(cfg)
    K = len(g)
    A = np.zeros((N_STATE + K, N_STATE + K))
    A[:N_STATE, :N_STATE] = A7
    A[4, 2] *= 1.0 + float(np.sum(g))
    for j in range(K):
        A[4, N_STATE + j] = -A7[4, 2]
        A[N_STATE + j, 2] = g[j] / tau[j]
        A[N_STATE + j, N_STATE + j] = -1.0 / tau[j]
    return A, np.concatenate([B7, np.zeros(K)])


def build_actuator(cfg: Config, n_sub: int | None = None, n_fine: int | None = None) -> ActuatorParams:
    """Constant arrays of ``_actuator_step`` for the configuration (controller step cfg.dt_s;
    reads cfg.actuator, its substeps and fine_substeps unless n_sub / n_fine are given, and the
    force sensors' bandwidths in cfg.sensors)."""
    n_sub = cfg.actuator.substeps if n_sub is None else n_sub
    n_fine = cfg.actuator.fine_substeps if n_fine is None else n_fine
    if int(n_sub) < 1 or int(n_fine) < 1:
        raise ValueError(f"n_sub = {n_sub}, n_fine = {n_fine}: both must be >= 1")
    a = cfg.actuator
    h = cfg.dt_s / int(n_sub)
    h_f = h / int(n_fine)
    sc = stack_constants(cfg)
    x_per_V = a.c_v / a.k_screw
    wn = math.sqrt(sc["K"] / sc["m"])
    if a.creep_per_decade == 0.0:  # the 7-state chain (kept apart: bit-identical runs without creep)
        A, B, _, _ = actuator_ss(cfg)
        g = np.zeros(0)
    else:
        A, B = creep_ss(cfg)
        g = creep_constants(cfg)[1]
    K = len(g)
    scale = np.concatenate([[1.0, 1.0, 1.0, x_per_V, x_per_V * wn, a.c_v, a.c_v], g])  # per volt

    def block(step):
        Phi, G0, _ = discretise(A, B, step, scale)
        Pm, Gm0, Gm1 = discretise(A[3:, 3:], A[3:, 2], step, scale[3:])
        M = np.zeros((N_STATE, 14))
        M[:, :7] = Phi[:N_STATE, :N_STATE]
        M[:, 7] = G0[:N_STATE, 0]
        M[3:, 8:12] = Pm[:4, :4]
        M[3:, 12] = Gm0[:4, 0]
        M[3:, 13] = Gm1[:4, 0]
        Q = np.zeros((K, 11))
        for j in range(K):
            q = N_STATE + j
            Q[j, 0:4] = Phi[3:N_STATE, q]
            Q[j, 4:7] = Phi[q, 0:3]
            Q[j, 7] = G0[q, 0]
            Q[j, 8] = Phi[q, q]
            Q[j, 9] = Gm0[4 + j, 0]
            Q[j, 10] = Gm1[4 + j, 0]
        return M, Q

    lsb = (a.V_max - a.V_min) / (2 ** a.dac_bits - 1)
    hyst_A, hyst_beta = hysteresis_constants(cfg)
    M, Q = block(h)
    M_f, Q_f = block(h_f)
    p = ActuatorParams(
        V_min=float(a.V_min), V_max=float(a.V_max), lsb=float(lsb), inv_lsb=float(1.0 / lsb),
        w_a=float(2.0 * math.pi * a.amp_bandwidth_hz), L=float(a.current_limit_A / a.capacitance_F),
        C=float(a.capacitance_F), n_sub=int(n_sub), h=float(h), M=M,
        n_fine=int(n_fine), h_f=float(h_f), M_f=M_f,
        F0=float(a.F0_N), k_screw=float(a.k_screw), x_per_V=float(x_per_V),
        hyst_A=float(hyst_A), hyst_beta=float(hyst_beta),
        n_creep=int(K), creep_g=np.ascontiguousarray(g, dtype=np.float64), Q=Q, Q_f=Q_f)
    for arr in p:
        if isinstance(arr, np.ndarray):
            arr.setflags(write=False)
    return p


def slot_index() -> dict[str, int]:
    """Name -> index in the actuator state vector."""
    return {nm: i for i, nm in enumerate(ACTUATOR_SLOTS)}


def output_index() -> dict[str, int]:
    """Name -> index in the actuator output vector."""
    return {nm: i for i, (nm, _) in enumerate(ACTUATOR_OUTPUTS)}


def initial_state(p: ActuatorParams, V: float | None = None, F_N1: float | None = None) -> np.ndarray:
    """Rest state at amplifier voltage V [V] (or at the voltage giving F_N1 [N] statically,
    F_N1 = F0 + c_v V; default V_min), energy 0, hysteresis state h = 0 (a stack at rest after
    demagnetising, on its virgin curve), creep states at their rest q_j = g_j V (a bolt held at V
    for long, so F_N1 stays at F0 + c_v V). V must lie in [V_min, V_max]."""
    if V is None:
        V = p.V_min if F_N1 is None else (F_N1 - p.F0) / (p.k_screw * p.x_per_V)
    if not (p.V_min <= V <= p.V_max):
        raise ValueError(f"initial voltage {V:g} V lies outside the amplifier range [{p.V_min:g}, {p.V_max:g}] V")
    x = np.zeros(len(ACTUATOR_SLOTS))
    x[0] = V
    x[2] = V
    x[3] = p.x_per_V * V
    x[5] = x[6] = p.F0 + p.k_screw * x[3]
    x[Q0:Q0 + p.n_creep] = p.creep_g * V
    return x


# --- run time --------------------------------------------------------------------------------

@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy", inline="always")
def _dac(V_cmd, V_min, V_max, lsb, inv_lsb):
    """DAC output [V]: V_min + n LSB, n = rint((clip(V_cmd, V_min, V_max) - V_min) / LSB) (ties to
    even), LSB = (V_max - V_min) / (2^bits - 1); a NaN command gives V_min. RT-safe."""
    if V_cmd >= V_max:
        V_cmd = V_max
    elif not V_cmd > V_min:  # below the range, or NaN: the safe end
        V_cmd = V_min
    return V_min + np.rint((V_cmd - V_min) * inv_lsb) * lsb


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy", inline="always")
def _energy(Va0, Va1, half_C):
    """Energy the amplifier delivers while V_a moves monotonically from Va0 to Va1 [V]:
    integral |V_a C V_a'| dt = C/2 |Va1^2 - Va0^2|, or C/2 (Va0^2 + Va1^2) through zero [J]. RT-safe."""
    if Va0 * Va1 >= 0.0:
        return half_C * abs(Va1 * Va1 - Va0 * Va0)
    return half_C * (Va0 * Va0 + Va1 * Va1)


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy", inline="always")
def _hysteresis(h0, dV, A, beta):
    """Bouc-Wen state [V] after a monotone change dV [V] of V_a from h0: the exact solution of
    dh/dV_a = A - beta sign(dV) h,  h1 = h_s + (h0 - h_s) e^{-beta |dV|},  h_s = sign(dV) A / beta
    (rate independent: it depends on the path of V_a only). RT-safe."""
    if dV == 0.0:
        return h0
    hs = A / beta if dV > 0.0 else -A / beta
    return h0 - (hs - h0) * math.expm1(-beta * abs(dV))


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy", inline="always")
def _creep_into_stack(q, Q, n_creep, x1, v1, zs1, zc1):
    """Add the creep states' part of one fine substep's update to the stack and sensor states:
    x1 += sum_j Q[j, 0] q_j, x1' += sum_j Q[j, 1] q_j, z_s1 += sum_j Q[j, 2] q_j, z_c1 += sum_j Q[j, 3] q_j,
    q_j = q[Q0 + j] at the substep's start (the same in both regimes of ``_actuator_fine``). RT-safe."""
    for j in range(n_creep):
        qj = q[Q0 + j]
        x1 += Q[j, 0] * qj
        v1 += Q[j, 1] * qj
        zs1 += Q[j, 2] * qj
        zc1 += Q[j, 3] * qj
    return x1, v1, zs1, zc1


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy")
def _actuator_fine(vf, r, Va, xm, vm, zs, zc, Vd, p, q):
    """One substep h as p.n_fine substeps of h_f = h / n_fine (a substep where the amplifier
    changes regime): linear update, its V_a change clipped to +-L h_f and to [V_min, V_max], the
    stack and sensors by the ramp update where clipped; the creep states q[Q0:Q0 + n_creep] (the
    caller's next state) advanced in place by p.Q_f in the same regime. Returns (v_f, r, V_a, x,
    x', z_s, z_c, dE). RT-safe."""
    M = p.M_f
    Q = p.Q_f
    V_min, V_max = p.V_min, p.V_max
    slew = p.L * p.h_f
    half_C = 0.5 * p.C
    dE = 0.0
    for _ in range(p.n_fine):
        vf1 = M[0, 0] * vf + M[0, 1] * r + M[0, 7] * Vd
        r1 = M[1, 0] * vf + M[1, 1] * r + M[1, 7] * Vd
        Va1 = M[2, 0] * vf + M[2, 1] * r + M[2, 2] * Va + M[2, 7] * Vd
        Va1c = min(max(Va1, Va - slew), Va + slew)
        Va1c = min(max(Va1c, V_min), V_max)
        if Va1c != Va1:
            dV = Va1c - Va
            x1 = M[3, 8] * xm + M[3, 9] * vm + M[3, 12] * Va + M[3, 13] * dV
            v1 = M[4, 8] * xm + M[4, 9] * vm + M[4, 12] * Va + M[4, 13] * dV
            zs1 = M[5, 8] * xm + M[5, 9] * vm + M[5, 10] * zs + M[5, 12] * Va + M[5, 13] * dV
            zc1 = M[6, 8] * xm + M[6, 9] * vm + M[6, 11] * zc + M[6, 12] * Va + M[6, 13] * dV
            x1, v1, zs1, zc1 = _creep_into_stack(q, Q, p.n_creep, x1, v1, zs1, zc1)
            for j in range(p.n_creep):
                q[Q0 + j] = Q[j, 8] * q[Q0 + j] + Q[j, 9] * Va + Q[j, 10] * dV
        else:
            x1 = (M[3, 0] * vf + M[3, 1] * r + M[3, 2] * Va + M[3, 3] * xm + M[3, 4] * vm
                  + M[3, 7] * Vd)
            v1 = (M[4, 0] * vf + M[4, 1] * r + M[4, 2] * Va + M[4, 3] * xm + M[4, 4] * vm
                  + M[4, 7] * Vd)
            zs1 = (M[5, 0] * vf + M[5, 1] * r + M[5, 2] * Va + M[5, 3] * xm + M[5, 4] * vm
                   + M[5, 5] * zs + M[5, 7] * Vd)
            zc1 = (M[6, 0] * vf + M[6, 1] * r + M[6, 2] * Va + M[6, 3] * xm + M[6, 4] * vm
                   + M[6, 6] * zc + M[6, 7] * Vd)
            x1, v1, zs1, zc1 = _creep_into_stack(q, Q, p.n_creep, x1, v1, zs1, zc1)
            for j in range(p.n_creep):
                q[Q0 + j] = Q[j, 4] * vf + Q[j, 5] * r + Q[j, 6] * Va + Q[j, 7] * Vd + Q[j, 8] * q[Q0 + j]
        dE += _energy(Va, Va1c, half_C)
        vf, r, Va, xm, vm, zs, zc = vf1, r1, Va1c, x1, v1, zs1, zc1
    return vf, r, Va, xm, vm, zs, zc, dE


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy")
def _actuator_step(k, x, u, p, x_next, y):
    """Advance the actuator chain over one controller step [t_k, t_{k+1}].

    Parameters
    ----------
    k : int64 tick (the chain is time-invariant; kept for the uniform step signature)
    x : (14,) state at t_k, slots ``ACTUATOR_SLOTS`` = v_f [V], r [V], V_a [V], x [m], x' [m/s],
        F_strain_a [N], F_cell_a [N], E [J], h [V], q_0..q_4 [V] (read only)
    u : (1,) u[0] = V_cmd [V], the controller's DAC command, held over the step
    p : ActuatorParams
    x_next : (14,) state at t_{k+1} (written)
    y : (9,) outputs ``ACTUATOR_OUTPUTS`` (written): F_N1 [N], V_dac [V], v_f [V], V_a [V],
        i [A], P [W], E [J], F_strain_a [N], F_cell_a [N]

    Per substep of h (module docstring), with s = w_a (v_f - V_a) at both ends of the linear
    update s1 = Ad s0 + Bd V_dac:
        linear   |s0|, |s1| <= L, V_a1 inside [V_min, V_max]        -> s1
        slewing  s0, s1 > L (or < -L) with V_a1 = V_a0 +- L h inside the rails
        held     V_a0 on a rail, s0 and v_f1 pushing outwards         -> V_a1 = V_a0
                 (both: m1 = Pm m0 + Gm0 V_a0 + Gm1 (V_a1 - V_a0), m = [x, x', z_s, z_c])
        else     n_fine substeps of h / n_fine (``_actuator_fine``)
    Hysteresis (p.hyst_A > 0): h1 = ``_hysteresis``(h0, V_a1 - V_a0) and the stack's input
    V_a - h, so m1 -= Gm0 h0 + Gm1 (h1 - h0) (superposition; h taken linear over the substep).
    Creep (p.n_creep > 0): the stack's input (1 + G) (V_a - h) - sum_j q_j, exact through the
    augmented blocks (M, and p.Q for the q_j rows and columns, ``ActuatorParams``); the -h input
    reaches q_j by the same superposition, q_j1 -= G0_j h0 + G1_j (h1 - h0).
    E += C/2 |V_a1^2 - V_a0^2|;  F_N1 = F0 + k_screw x;  i = C (V_a1 - V_a0) / h and
    P = i (V_a0 + V_a1) / 2 over the last substep.
    RT-safe (no allocation, no Python objects).
    """
    # NamedTuple fields and matrix entries into locals (numba would reload them in the loop)
    M = p.M
    V_min, V_max, w_a, L, C, h, F0 = p.V_min, p.V_max, p.w_a, p.L, p.C, p.h, p.F0
    a00, a01, a10, a11 = M[0, 0], M[0, 1], M[1, 0], M[1, 1]
    a20, a21, a22 = M[2, 0], M[2, 1], M[2, 2]
    a30, a31, a32, a33, a34 = M[3, 0], M[3, 1], M[3, 2], M[3, 3], M[3, 4]
    a40, a41, a42, a43, a44 = M[4, 0], M[4, 1], M[4, 2], M[4, 3], M[4, 4]
    a50, a51, a52, a53, a54, a55 = M[5, 0], M[5, 1], M[5, 2], M[5, 3], M[5, 4], M[5, 5]
    a60, a61, a62, a63, a64, a66 = M[6, 0], M[6, 1], M[6, 2], M[6, 3], M[6, 4], M[6, 6]
    b0, b1, b2, b3, b4, b5, b6 = M[0, 7], M[1, 7], M[2, 7], M[3, 7], M[4, 7], M[5, 7], M[6, 7]
    p00, p01, p10, p11 = M[3, 8], M[3, 9], M[4, 8], M[4, 9]
    p20, p21, p22, p30, p31, p33 = M[5, 8], M[5, 9], M[5, 10], M[6, 8], M[6, 9], M[6, 11]
    g0, g1, g2, g3 = M[3, 12], M[4, 12], M[5, 12], M[6, 12]
    q0, q1, q2, q3 = M[3, 13], M[4, 13], M[5, 13], M[6, 13]
    slew = L * h
    half_C = 0.5 * C

    Vd = _dac(u[0], V_min, V_max, p.lsb, p.inv_lsb)
    vf, r, Va, xm, vm, E, hb = x[0], x[1], x[2], x[3], x[4], x[7], x[8]
    hA, hbeta = p.hyst_A, p.hyst_beta
    zs = x[5] - F0
    zc = x[6] - F0
    Q = p.Q
    nq = p.n_creep
    for j in range(CREEP_DECADES):  # creep states advance in place in x_next
        x_next[Q0 + j] = x[Q0 + j]
    Va_prev = Va
    for _ in range(p.n_sub):
        vf1 = a00 * vf + a01 * r + b0 * Vd
        r1 = a10 * vf + a11 * r + b1 * Vd
        Va1 = a20 * vf + a21 * r + a22 * Va + b2 * Vd
        s0 = w_a * (vf - Va)
        s1 = w_a * (vf1 - Va1)
        ramp = True
        fine = False
        if -L <= s0 <= L and -L <= s1 <= L and V_min <= Va1 <= V_max:  # linear
            ramp = False
        elif s0 > L and Va + slew <= V_max and w_a * (vf1 - Va - slew) > L:  # slewing up
            Va1 = Va + slew
        elif s0 < -L and Va - slew >= V_min and w_a * (vf1 - Va + slew) < -L:  # slewing down
            Va1 = Va - slew
        elif (Va == V_max and s0 > 0.0 and vf1 > V_max) or (Va == V_min and s0 < 0.0 and vf1 < V_min):
            Va1 = Va  # held at a rail
        else:  # the regime changes within the substep
            fine = True
        if fine:
            vf1, r1, Va1, x1, v1, zs1, zc1, dE = _actuator_fine(vf, r, Va, xm, vm, zs, zc, Vd, p, x_next)
            E += dE
        else:
            if ramp:
                dV = Va1 - Va
                x1 = p00 * xm + p01 * vm + g0 * Va + q0 * dV
                v1 = p10 * xm + p11 * vm + g1 * Va + q1 * dV
                zs1 = p20 * xm + p21 * vm + p22 * zs + g2 * Va + q2 * dV
                zc1 = p30 * xm + p31 * vm + p33 * zc + g3 * Va + q3 * dV
            else:
                x1 = a30 * vf + a31 * r + a32 * Va + a33 * xm + a34 * vm + b3 * Vd
                v1 = a40 * vf + a41 * r + a42 * Va + a43 * xm + a44 * vm + b4 * Vd
                zs1 = a50 * vf + a51 * r + a52 * Va + a53 * xm + a54 * vm + a55 * zs + b5 * Vd
                zc1 = a60 * vf + a61 * r + a62 * Va + a63 * xm + a64 * vm + a66 * zc + b6 * Vd
            for j in range(nq):  # creep: the response to q_j0, then q_j's own update
                qj = x_next[Q0 + j]
                x1 += Q[j, 0] * qj
                v1 += Q[j, 1] * qj
                zs1 += Q[j, 2] * qj
                zc1 += Q[j, 3] * qj
                if ramp:
                    x_next[Q0 + j] = Q[j, 8] * qj + Q[j, 9] * Va + Q[j, 10] * (Va1 - Va)
                else:
                    x_next[Q0 + j] = Q[j, 4] * vf + Q[j, 5] * r + Q[j, 6] * Va + Q[j, 7] * Vd + Q[j, 8] * qj
            E += _energy(Va, Va1, half_C)
        if hA > 0.0:  # hysteresis: the stack input is V_a - h, h a first-order hold over the substep
            h1 = _hysteresis(hb, Va1 - Va, hA, hbeta)
            dh = h1 - hb
            x1 -= g0 * hb + q0 * dh
            v1 -= g1 * hb + q1 * dh
            zs1 -= g2 * hb + q2 * dh
            zc1 -= g3 * hb + q3 * dh
            for j in range(nq):
                x_next[Q0 + j] -= Q[j, 9] * hb + Q[j, 10] * dh
            hb = h1
        Va_prev = Va
        vf, r, Va, xm, vm, zs, zc = vf1, r1, Va1, x1, v1, zs1, zc1
    x_next[0] = vf
    x_next[1] = r
    x_next[2] = Va
    x_next[3] = xm
    x_next[4] = vm
    x_next[5] = F0 + zs
    x_next[6] = F0 + zc
    x_next[7] = E
    x_next[8] = hb
    i = C * (Va - Va_prev) / h
    y[0] = F0 + p.k_screw * xm
    y[1] = Vd
    y[2] = vf
    y[3] = Va
    y[4] = i
    y[5] = 0.5 * (Va_prev + Va) * i
    y[6] = E
    y[7] = F0 + zs
    y[8] = F0 + zc


def actuator_step(k: int, x: np.ndarray, u: np.ndarray, p: ActuatorParams, x_next: np.ndarray,
                  y: np.ndarray) -> None:
    """Checked wrapper of ``_actuator_step`` (call the kernel directly inside loops)."""
    n = len(ACTUATOR_SLOTS)
    if x.shape != (n,) or x_next.shape != (n,):
        raise ValueError(f"actuator state must have shape ({n},) (slots {ACTUATOR_SLOTS}), got {x.shape}, "
                         f"{x_next.shape}")
    if u.shape != (1,):
        raise ValueError(f"actuator input must be (V_cmd [V],), got shape {u.shape}")
    if y.shape != (len(ACTUATOR_OUTPUTS),):
        raise ValueError(f"actuator output must have shape ({len(ACTUATOR_OUTPUTS)},), got {y.shape}")
    for a in (x, u, x_next, y):
        if a.dtype != np.float64 or not a.flags.c_contiguous:
            raise ValueError("actuator arrays must be contiguous float64")
    _actuator_step(np.int64(k), x, u, p, x_next, y)


@numba.njit(cache=True, nogil=True)
def _actuator_run(x0, V_cmd, p, X, Y):
    """Step the chain over the commands V_cmd (n,) [V] from x0: X (n + 1, 14) states, Y (n, 9)
    outputs (filled)."""
    X[0] = x0
    for k in range(V_cmd.shape[0]):
        _actuator_step(k, X[k], V_cmd[k:k + 1], p, X[k + 1], Y[k])


def run_actuator(p: ActuatorParams, V_cmd: np.ndarray, x0: np.ndarray | None = None):
    """Offline run over a command sequence V_cmd [V] (one per controller step).

    Returns (X (n + 1, 14) states at t_0..t_n, Y (n, 9) outputs at t_1..t_n)."""
    V_cmd = np.ascontiguousarray(V_cmd, dtype=np.float64)
    x0 = initial_state(p) if x0 is None else np.ascontiguousarray(x0, dtype=np.float64)
    X = np.empty((len(V_cmd) + 1, len(ACTUATOR_SLOTS)))
    Y = np.empty((len(V_cmd), len(ACTUATOR_OUTPUTS)))
    _actuator_run(x0, V_cmd, p, X, Y)
    return X, Y
