"""Force tracking (SPEC section 3): the piezo voltage that makes the adaptive screw's force F_N1
follow the law's setpoint F*. Feedforward from the inverse static voltage-force relation plus a
PID on the measured force, with conditional-integration anti-windup and output limits.

Run time (``_force_tracking_step``), e = F* - F_meas:

    V_ff = (F* - F0) / c_v                      inverse of F = F0 + c_v V (SPEC 3)
    I_k  = I_{k-1} + Ki dt e_k                  backward-Euler integral (clamped, see below)
    D_k  = Tf/(Tf+dt) D_{k-1} - Kd/(Tf+dt) (F_meas,k - F_meas,k-1)
                                                Kd s/(1 + Tf s) on -F_meas, backward Euler
    V    = sat(V_ff + Kp e_k + I_k + D_k),      sat to [V_min, V_max] (actuator.V_min/V_max)

The derivative acts on the measurement, not on e: the laws' setpoint jumps (bang-bang), and a
derivative of the setpoint would kick the output; the setpoint path is the feedforward's job.
Anti-windup by conditional integration (clamping): an integral step that would take the output
beyond a limit in the direction of the step is shortened so that the output lands on the limit,
and skipped if the integral is already there or beyond (it is never moved further out). While
saturated the integral therefore sits at the headroom V_max - (V_ff + Kp e + D) (or V_min - ...)
and the output at the limit; it resumes as soon as the error changes sign or the feedforward
moves the output back inside. No tuning constant (back-calculation would need a tracking time
constant), and the output does reach the limit (skipping the whole step would leave it up to
one integral step short of it).

Design time (``design_force_tracking``): loop shaping on the small-signal actuator model

    G(s) = c_v H_lp(s) H_amp(s) H_mech(s) H_sens(s)   [N/V],  discretised with a ZOH at dt,

PI gains placing the open-loop crossover of L(z) = C(z) G(z) at ``tracking.pid_bandwidth_hz``
with ``tracking.pid_phase_margin_deg`` where a PI can (docs/tracking.md, section 3), and a
closed-loop stability check that refuses unstable gains with a clear error.

State slots ``FORCE_TRACKING_SLOTS`` = (integ [V], deriv [V], F_meas_prev [N]).
Inputs u = (F_set [N], F_meas [N]). Outputs y = (V_cmd [V], saturated [-]: +1 at V_max,
-1 at V_min, 0 inside the limits).
"""
from __future__ import annotations

import importlib.util
import math
import warnings
from dataclasses import dataclass
from typing import NamedTuple

import control
import numba
import numpy as np
import scipy.optimize as so

from frictionrt.rt.common.config import Config

_HAS_SLYCOT = importlib.util.find_spec("slycot") is not None  # python-control then evaluates by Slycot's tb05ad

FORCE_TRACKING_SLOTS = ("integ", "deriv", "F_meas_prev")
FORCE_TRACKING_INPUTS = (("F_set", "N"), ("F_meas", "N"))
FORCE_TRACKING_OUTPUTS = (("V_cmd", "V"), ("saturated", "-"))
SENSORS = ("strain", "cell")
SENSOR_OF_LAW = {"passive": "strain", "hysteresis": "strain", "lyapunov": "cell"}  # SPEC 3
# Ki >= I_CORNER_MIN wc Kp: the integral corner stays within a decade of the crossover, so a PI
# never degenerates into a P controller (it would lose zero steady-state error in practice)
I_CORNER_MIN = 0.1
DERIV_FILTER_HZ = 3000.0  # corner of the derivative filter, Tf = 1/(2 pi f); used when Kd != 0
PM_SLACK_DEG = 1.0        # warn when the reached phase margin misses the target by more


class ForceTrackingParams(NamedTuple):
    """Constants of the force-tracking step (built by ``build_force_tracking``)."""
    Kp: float        # proportional gain [V/N]
    Ki_dt: float     # Ki dt, integral gain times the step [V/N]
    d_pole: float    # Tf / (Tf + dt) [-]
    d_gain: float    # Kd / (Tf + dt) [V/N]
    F0: float        # force at 0 V [N]
    inv_c_v: float   # 1 / c_v [V/N]
    V_min: float     # [V]
    V_max: float     # [V]


# --- run time -------------------------------------------------------------------------------

@numba.njit(cache=True, nogil=True, _nrt=False)
def _force_tracking_step(k, x, u, p, x_next, y):
    """Feedforward + PID with conditional-integration anti-windup and output limits. RT-safe.

        e = F* - F_meas,   V_ff = (F* - F0) / c_v                       (SPEC 3)
        D_k = Tf/(Tf+dt) D_{k-1} - Kd/(Tf+dt) (F_meas,k - F_meas,k-1)
        v_free = V_ff + Kp e + D_k,   hi = V_max - v_free,   lo = V_min - v_free
        I_k = I_{k-1} + Ki dt e      unless that passes hi upwards (then max(I_{k-1}, hi))
                                     or lo downwards (then min(I_{k-1}, lo))
        V_cmd = V_max if I_k >= hi,  V_min if I_k <= lo,  else v_free + I_k

    Parameters
    ----------
    k : int64 tick (the controller is time-invariant; kept for the uniform step signature)
    x : (3,) state at t_k, ``FORCE_TRACKING_SLOTS`` = (I_{k-1} [V], D_{k-1} [V],
        F_meas,k-1 [N]) (read only)
    u : (2,) inputs (F_set [N], F_meas [N]) at t_k
    p : ForceTrackingParams
    x_next : (3,) state (I_k, D_k, F_meas,k) (written)
    y : (2,) outputs (V_cmd [V], saturated: +1 at V_max, -1 at V_min, 0 inside) (written)
    """
    Kp, Ki_dt, d_pole, d_gain = p.Kp, p.Ki_dt, p.d_pole, p.d_gain
    F0, inv_c_v, V_min, V_max = p.F0, p.inv_c_v, p.V_min, p.V_max
    F_set = u[0]
    F_meas = u[1]
    integ = x[0]
    e = F_set - F_meas
    d = d_pole * x[1] - d_gain * (F_meas - x[2])
    v_free = (F_set - F0) * inv_c_v + Kp * e + d  # everything but the integral
    hi = V_max - v_free  # integral values that put the output on a limit
    lo = V_min - v_free
    di = Ki_dt * e
    trial = integ + di
    if di > 0.0 and trial > hi:    # would push the output beyond V_max: up to it, never further
        integ = max(integ, hi)
    elif di < 0.0 and trial < lo:  # likewise below V_min
        integ = min(integ, lo)
    else:
        integ = trial
    if integ >= hi:
        v = V_max
        sat = 1.0
    elif integ <= lo:
        v = V_min
        sat = -1.0
    else:
        v = v_free + integ
        sat = 0.0
    x_next[0] = integ
    x_next[1] = d
    x_next[2] = F_meas
    y[0] = v
    y[1] = sat


def force_tracking_step(k: int, x: np.ndarray, u: np.ndarray, p: ForceTrackingParams,
                        x_next: np.ndarray, y: np.ndarray) -> None:
    """Checked wrapper of ``_force_tracking_step`` (use the kernel directly in loops)."""
    n = len(FORCE_TRACKING_SLOTS)
    if x.shape != (n,) or x_next.shape != x.shape:
        raise ValueError(f"state must have shape ({n},) = {FORCE_TRACKING_SLOTS}, "
                         f"got {x.shape}, {x_next.shape}")
    if u.shape != (2,) or y.shape != (2,):
        raise ValueError(f"u must be (F_set [N], F_meas [N]) and y (V_cmd [V], saturated); "
                         f"got shapes {u.shape}, {y.shape}")
    _force_tracking_step(np.int64(k), x, u, p, x_next, y)


def initial_state(F_meas0: float, integ0: float = 0.0) -> np.ndarray:
    """State at tick 0 without a derivative kick: F_meas,-1 = F_meas0, D = 0, I = integ0 [V]."""
    return np.array([float(integ0), 0.0, float(F_meas0)])


# --- design time: models ----------------------------------------------------------------------

def _first_order(w: float):
    """w / (s + w) as (A, B, C)."""
    return np.array([[-w]]), np.array([[w]]), np.array([[1.0]])


def _second_order(w: float, zeta: float):
    """w^2 / (s^2 + 2 zeta w s + w^2) as (A, B, C), states (y, y'/w) (balanced scaling)."""
    return (np.array([[0.0, w], [-w, -2.0 * zeta * w]]), np.array([[0.0], [w]]),
            np.array([[1.0, 0.0]]))


def actuator_model(cfg: Config, sensor: str) -> control.StateSpace:
    """Continuous small-signal model V -> (F, F_meas) of the actuator chain (SPEC 3).

        F      = c_v H_lp H_amp H_mech V         deviation of F_N1 from F0 [N]
        F_meas = H_sens F                        measured force deviation [N]

        H_lp   = w^2 / (s^2 + sqrt(2) w s + w^2),   w = 2 pi actuator.lowpass_hz
        H_amp  = wa / (s + wa),                     wa = 2 pi actuator.amp_bandwidth_hz
        H_mech = wm^2 / (s^2 + 2 zeta wm s + wm^2), wm^2 = (k_stack + k_screw) / moving_mass_kg
        H_sens = ws / (s + ws),  ws = 2 pi sensors.strain_bandwidth_hz | cell_bandwidth_hz

    Built as a chain of small state-space blocks (a 6th-order transfer-function polynomial
    would have coefficients spanning ~25 decades).
    """
    if sensor not in SENSORS:
        raise ValueError(f"sensor = {sensor!r}: must be one of {', '.join(SENSORS)}")
    a, s = cfg.actuator, cfg.sensors
    f_sens = s.strain_bandwidth_hz if sensor == "strain" else s.cell_bandwidth_hz
    wm = math.sqrt((a.k_stack + a.k_screw) / a.moving_mass_kg)
    blocks = [_second_order(2 * math.pi * a.lowpass_hz, 1 / math.sqrt(2)),
              _first_order(2 * math.pi * a.amp_bandwidth_hz),
              _second_order(wm, a.zeta_stack),
              _first_order(2 * math.pi * f_sens)]
    n = sum(b[0].shape[0] for b in blocks)
    A = np.zeros((n, n))
    B = np.zeros((n, 1))
    C = np.zeros((2, n))
    o, prev = 0, None
    for i, (Ai, Bi, Ci) in enumerate(blocks):
        m = Ai.shape[0]
        A[o:o + m, o:o + m] = Ai
        if prev is None:
            B[o:o + m] = Bi
        else:  # input of this block = output of the previous one
            po, pC = prev
            A[o:o + m, po:po + pC.shape[1]] = Bi @ pC
        prev = (o, Ci)
        if i == 2:
            C[0, o:o + m] = a.c_v * Ci[0]  # F after the mechanics, gain c_v
        o += m
    C[1, o - 1] = a.c_v  # F_meas = c_v * (chain output); the gain is carried on the outputs
    return control.ss(A, B, C, np.zeros((2, 1)), inputs=["V"], outputs=["F", "F_meas"],
                      name="actuator")


def discrete_actuator_model(cfg: Config, sensor: str) -> control.StateSpace:
    """``actuator_model`` discretised with a zero-order hold at dt (the DAC holds V)."""
    return control.c2d(actuator_model(cfg, sensor), cfg.dt_s, "zoh", name="actuator")


def controller_model(p: ForceTrackingParams, dt: float) -> control.StateSpace:
    """The linear part of ``_force_tracking_step`` (no saturation) as a discrete system
    (F_set - F0, F_meas - F0) -> V with the kernel's state order; the derivative states are
    left out when Kd = 0 (they would only add two cancelled poles)."""
    Kp, Ki_dt, a_d, b_d, c = p.Kp, p.Ki_dt, p.d_pole, p.d_gain, p.inv_c_v
    # x = (I_{k-1}, D_{k-1}, y_{k-1});  I_k = x0 + Ki dt (r - y),  D_k = a_d x1 - b_d (y - x2)
    A = np.array([[1.0, 0.0, 0.0], [0.0, a_d, b_d], [0.0, 0.0, 0.0]])
    B = np.array([[Ki_dt, -Ki_dt], [0.0, -b_d], [0.0, 1.0]])
    C = np.array([[1.0, a_d, b_d]])
    D = np.array([[c + Kp + Ki_dt, -(Kp + Ki_dt + b_d)]])
    states = list(FORCE_TRACKING_SLOTS)
    if b_d == 0.0:
        A, B, C, states = A[:1, :1], B[:1], C[:, :1], states[:1]
    return control.ss(A, B, C, D, dt, inputs=["F_set", "F_meas"], outputs=["V"], states=states,
                      name="pid")


def closed_loop_model(cfg: Config, sensor: str, p: ForceTrackingParams) -> control.StateSpace:
    """Discrete closed loop F_set -> (F_meas, F, V) of the linear controller and the
    ZOH-discretised actuator model, deviations from F0 (forces) and 0 V (voltage)."""
    return _closed_loop(discrete_actuator_model(cfg, sensor), p, cfg.dt_s)


def _closed_loop(Gd, p: ForceTrackingParams, dt: float) -> control.StateSpace:
    # states: the actuator's, then the controller's (interconnect keeps the list order)
    return control.interconnect([Gd, controller_model(p, dt)], inputs=["F_set"],
                                outputs=["F_meas", "F", "V"], name="force_loop")


# --- design time: gains and figures -----------------------------------------------------------

@dataclass(frozen=True)
class ForceTrackingDesign:
    """Designed gains, the figures of the loop, and the kernel parameters.

    Figures are those of the discrete (ZOH) linear loop, below Nyquist; -3 dB bandwidths are
    inf when the magnitude does not fall 3 dB below its DC value before Nyquist.
    """
    sensor: str
    Kp: float                    # [V/N]
    Ki: float                    # [V/(N s)]
    Kd: float                    # [V s/N]
    Tf: float                    # derivative filter time constant [s]
    crossover_hz: float          # lowest |L| = 1
    phase_margin_deg: float      # at crossover_hz
    phase_margin_min_deg: float  # over all |L| = 1 (a resonance may add crossings)
    gain_margin_db: float        # smallest, inf if the phase of L never reaches -180 deg
    bandwidth_hz: float          # -3 dB of F_meas/F* (feedforward + PID)
    bandwidth_force_hz: float    # -3 dB of F/F* (the true screw force F_N1 - F0)
    bandwidth_fb_hz: float       # -3 dB of L/(1+L) (PID alone, no feedforward)
    peak_force_db: float         # largest |F/F*| [dB] (stack resonance excited by the feedforward)
    peak_force_hz: float
    max_pole_abs: float          # largest |z| of the closed-loop poles (< 1)
    params: ForceTrackingParams
    plant: control.StateSpace        # discrete G: V -> (F, F_meas) [N/V]
    closed_loop: control.StateSpace  # discrete F_set -> (F_meas, F, V)
    loop: control.StateSpace         # discrete L = C_fb G_meas (open loop, cut at F_meas)

    def summary(self) -> dict:
        """The gains and figures as plain floats (for reports and JSON)."""
        keys = ("Kp", "Ki", "Kd", "Tf", "crossover_hz", "phase_margin_deg", "phase_margin_min_deg",
                "gain_margin_db", "bandwidth_hz", "bandwidth_force_hz", "bandwidth_fb_hz",
                "peak_force_db", "peak_force_hz", "max_pole_abs")
        return {"sensor": self.sensor, **{k: float(getattr(self, k)) for k in keys}}


def force_tracking_params(cfg: Config, Kp: float, Ki: float, Kd: float = 0.0,
                          Tf: float | None = None) -> ForceTrackingParams:
    """Kernel constants from PID gains Kp [V/N], Ki [V/(N s)], Kd [V s/N] and the derivative
    filter time constant Tf [s] (default 1/(2 pi DERIV_FILTER_HZ))."""
    dt = cfg.dt_s
    Tf = 1.0 / (2 * math.pi * DERIV_FILTER_HZ) if Tf is None else float(Tf)
    a = cfg.actuator
    return ForceTrackingParams(Kp=float(Kp), Ki_dt=float(Ki * dt), d_pole=Tf / (Tf + dt),
                               d_gain=float(Kd) / (Tf + dt), F0=float(a.F0_N), inv_c_v=1.0 / a.c_v,
                               V_min=float(a.V_min), V_max=float(a.V_max))


def _freq(sys, w, dt: float, out: int = 0, inp: int = 0) -> np.ndarray:
    """Complex frequency response of a discrete system at w [rad/s] (z = exp(j w dt)).

    A state-space system with two or more states, at several frequencies and without Slycot, is
    evaluated as python-control's ``StateSpace.horner`` does without Slycot, H(z) = C (z I -
    A)^-1 B + D, by one LU solve per frequency, the frequencies stacked into one call of
    ``numpy.linalg.solve`` (bit for bit the point-by-point loop's values; a grid of 6000
    frequencies in one call instead of 6000); otherwise, or if a z I - A is singular,
    ``sys(z)`` itself."""
    z = np.exp(1j * np.atleast_1d(np.asarray(w, float)) * dt)
    if isinstance(sys, control.StateSpace) and sys.nstates > 1 and z.size > 1 and not _HAS_SLYCOT:
        A, B, C, D = (np.asarray(x) for x in (sys.A, sys.B, sys.C, sys.D))
        try:
            X = np.linalg.solve(z[:, None, None] * np.eye(A.shape[0]) - A, np.broadcast_to(B, (z.size,) + B.shape))
        except np.linalg.LinAlgError:
            pass
        else:
            return (C @ X + D)[:, out, inp]
    return sys(z, squeeze=False)[out, inp]


def _grid(dt: float, w_hi: float | None = None, n: int = 6000) -> np.ndarray:
    """Log grid from 0.1 Hz to w_hi (default just below Nyquist) [rad/s], fine enough to unwrap
    the phase across the lightly damped stack resonance (~1000 points per decade)."""
    w_hi = 0.9999 * math.pi / dt if w_hi is None else w_hi
    return np.geomspace(2 * math.pi * 0.1, w_hi, n)


def bandwidth_dt(sys, dt: float, out: int = 0, dbdrop: float = -3.0) -> float:
    """First frequency [Hz] where |sys| falls dbdrop below its DC gain, for a discrete system;
    inf if it does not below Nyquist. (python-control 0.10.2's ``bandwidth`` evaluates a
    discrete system at z = j w instead of exp(j w dt); fixed upstream in python-control#1212.)"""
    w = _grid(dt)
    h = np.abs(_freq(sys, w, dt, out))
    level = abs(h[0]) * 10 ** (dbdrop / 20)
    idx = np.nonzero(h < level)[0]
    if idx.size == 0:
        return math.inf
    i = idx[0]
    f = lambda x: abs(_freq(sys, np.array([x]), dt, out)[0]) - level  # noqa: E731
    return so.brentq(f, w[i - 1], w[i], xtol=1e-9, rtol=1e-13) / (2 * math.pi)


def margins_dt(L, dt: float) -> tuple[float, float, float, float]:
    """Stability margins of a discrete open loop L from its frequency response below Nyquist.

    Returns (crossover [Hz], phase margin there [deg], smallest phase margin over all gain
    crossovers [deg], gain margin [dB]). The crossover is the lowest |L| = 1 (the designed
    one); the phase there is unwrapped from DC, so a margin below -180 deg is not folded back.
    Further crossovers (a resonance lifting |L| above 1) enter the smallest margin, taken
    modulo 360 deg into (-180, 180] as ``control.stability_margins`` does. The gain margin is
    the smallest -20 log10 |L| where the phase crosses -180 deg (mod 360), inf if it never does.
    """
    w = _grid(dt)
    h = _freq(L, w, dt)
    mag, ph = np.abs(h), np.unwrap(np.angle(h))
    gain = lambda x: abs(_freq(L, x, dt)[0]) - 1.0  # noqa: E731
    idx = np.nonzero(np.diff(np.sign(mag - 1.0)))[0]
    if idx.size == 0:
        return math.nan, math.nan, math.nan, math.inf
    pms = []
    for i in idx:
        wc = so.brentq(gain, w[i], w[i + 1], xtol=1e-9, rtol=1e-13)
        hc = _freq(L, wc, dt)[0]
        phc = ph[i] + np.angle(hc / np.exp(1j * ph[i]))  # unwrapped phase at wc
        pms.append((wc, math.degrees(phc) + 180.0))
    wc0, pm0 = pms[0]
    pm_min = min((pm + 180.0) % 360.0 - 180.0 for _, pm in pms)
    turns = np.floor((ph + math.pi) / (2 * math.pi))  # index of the -180 deg (mod 360) band
    gms = []
    for j in np.nonzero(np.diff(turns))[0]:
        target = -math.pi + 2 * math.pi * max(turns[j], turns[j + 1])
        rot = np.exp(-1j * target)  # angle(L rot) crosses 0 there, away from its +-pi jump
        wp = so.brentq(lambda x: np.angle(_freq(L, x, dt)[0] * rot), w[j], w[j + 1],
                       xtol=1e-9, rtol=1e-13)
        gms.append(-20 * math.log10(abs(_freq(L, wp, dt)[0])))
    return wc0 / (2 * math.pi), pm0, pm_min, (min(gms) if gms else math.inf)


def peak_dt(sys, dt: float, out: int = 0) -> tuple[float, float]:
    """(largest |sys| [dB], its frequency [Hz]) below Nyquist of a discrete system."""
    w = _grid(dt)
    mag = np.abs(_freq(sys, w, dt, out))
    i = int(np.argmax(mag))
    if 0 < i < w.size - 1:  # refine on the parabola through the three grid points (log w)
        lw = np.log(w[i - 1:i + 2])
        c = np.polyfit(lw, mag[i - 1:i + 2], 2)
        if c[0] < 0:
            wi = math.exp(-c[1] / (2 * c[0]))
            return 20 * math.log10(abs(_freq(sys, wi, dt, out)[0])), wi / (2 * math.pi)
    return 20 * math.log10(mag[i]), w[i] / (2 * math.pi)


def design_force_tracking(cfg: Config, sensor: str) -> ForceTrackingDesign:
    """PI gains by loop shaping on the ZOH-discretised actuator model, the loop's figures, and
    a stability check.

    Procedure (docs/tracking.md, section 3). theta = w_c dt, w_c = 2 pi pid_bandwidth_hz,
    z_c = exp(j theta), g = G(z_c) with its phase phi_g unwrapped from DC. The controller
    C(z) = Kp + Ki dt z/(z-1) must give L(z_c) = C g = exp(j(PM - pi)), i.e.
    C(z_c) = exp(j phi_c)/|g|, phi_c = PM - pi - phi_g. A PI with Kp, Ki >= 0 reaches the
    phases [arg(dt z_c/(z_c-1)), 0] = [theta/2 - pi/2, 0]; phi_c is clipped into
    [theta/2 - pi/2, -atan(I_CORNER_MIN)]. At the lower end (the plant lags too little for the
    target margin) the controller is a pure integrator: the crossover is met, the margin is
    larger than asked and the integral gain is the largest any PI with that crossover and at
    least that margin has. Then Ki = Im(c)/Im(iota), Kp = Re(c) - Ki Re(iota) with
    c = exp(j phi_c)/|g| and iota = dt z_c/(z_c - 1).

    Raises ValueError if the crossover is not below Nyquist, or if a closed-loop pole is not
    strictly inside the unit circle (naming the gains, the pole and the keys to change).
    Warns if the reached phase margin is below the target by more than PM_SLACK_DEG.
    """
    if sensor not in SENSORS:
        raise ValueError(f"sensor = {sensor!r}: must be one of {', '.join(SENSORS)}")
    t, dt = cfg.tracking, cfg.dt_s
    f_nyq = 0.5 / dt
    if not t.pid_bandwidth_hz < f_nyq:
        raise ValueError(f"tracking.pid_bandwidth_hz = {t.pid_bandwidth_hz:g} Hz is not below the "
                         f"controller's Nyquist frequency {f_nyq:g} Hz (rt.rate_hz / 2)")
    Gd = discrete_actuator_model(cfg, sensor)
    G_meas = Gd[1, 0]
    wc = 2 * math.pi * t.pid_bandwidth_hz
    theta = wc * dt
    # --- plant at the crossover, phase unwrapped from DC
    w = _grid(dt, wc)
    ph = np.unwrap(np.angle(_freq(G_meas, w, dt)))
    g = _freq(G_meas, np.array([wc]), dt)[0]
    phi_g = ph[-1] + np.angle(g / np.exp(1j * ph[-1]))
    # --- PI in the discrete domain
    zc = np.exp(1j * theta)
    iota = dt * zc / (zc - 1.0)
    pm = math.radians(t.pid_phase_margin_deg)
    phi_c = min(max(pm - math.pi - phi_g, np.angle(iota)), -math.atan(I_CORNER_MIN))
    if phi_c <= np.angle(iota):
        Kp, Ki = 0.0, 1.0 / (abs(g) * abs(iota))
    else:
        c = np.exp(1j * phi_c) / abs(g)
        Ki = c.imag / iota.imag
        Kp = c.real - Ki * iota.real
    Kd, Tf = 0.0, 1.0 / (2 * math.pi * DERIV_FILTER_HZ)
    p = force_tracking_params(cfg, Kp, Ki, Kd, Tf)
    # --- closed loop and stability check
    cl = _closed_loop(Gd, p, dt)
    poles = cl.poles()
    a = cfg.actuator
    wm_hz = math.sqrt((a.k_stack + a.k_screw) / a.moving_mass_kg) / (2 * math.pi)
    worst = poles[np.argmax(np.abs(poles))]
    if not np.abs(worst) < 1.0:
        raise ValueError(
            f"Unstable PID gains for force tracking with the {sensor} sensor: Kp = {Kp:.6g} V/N, "
            f"Ki = {Ki:.6g} V/(N s), Kd = {Kd:.6g} V s/N give the closed-loop pole z = {worst:.6g} "
            f"(|z| = {abs(worst):.6g} >= 1, {abs(np.angle(worst)) / (2 * math.pi * dt):.0f} Hz). "
            f"Lower tracking.pid_bandwidth_hz (now {t.pid_bandwidth_hz:g} Hz; the piezo stack "
            f"resonance at {wm_hz:.0f} Hz and sensors.{sensor}_bandwidth_hz limit it) or change the "
            f"actuator model (actuator.k_stack, k_screw, moving_mass_kg, zeta_stack).")
    # --- figures
    L = -controller_model(p, dt)[0, 1] * G_meas  # loop cut at F_meas: C_fb = -dV/dF_meas
    f_c, pm_deg, pm_min, gm_db = margins_dt(L, dt)
    if pm_min < t.pid_phase_margin_deg - PM_SLACK_DEG:
        warnings.warn(f"force tracking ({sensor}): phase margin {pm_min:.1f} deg (crossover "
                      f"{f_c:.0f} Hz: {pm_deg:.1f} deg) is below tracking.pid_phase_margin_deg = "
                      f"{t.pid_phase_margin_deg:g} deg: a PI cannot add the lead the actuator model "
                      f"needs there, or its resonance crosses 0 dB; lower tracking.pid_bandwidth_hz "
                      f"(now {t.pid_bandwidth_hz:g} Hz)", RuntimeWarning, stacklevel=2)
    peak_db, peak_hz = peak_dt(cl, dt, out=1)
    return ForceTrackingDesign(
        sensor=sensor, Kp=float(Kp), Ki=float(Ki), Kd=Kd, Tf=float(Tf),
        crossover_hz=f_c, phase_margin_deg=pm_deg, phase_margin_min_deg=pm_min, gain_margin_db=gm_db,
        bandwidth_hz=bandwidth_dt(cl, dt, out=0), bandwidth_force_hz=bandwidth_dt(cl, dt, out=1),
        bandwidth_fb_hz=bandwidth_dt(control.feedback(L, 1), dt),
        peak_force_db=peak_db, peak_force_hz=peak_hz, max_pole_abs=float(abs(worst)),
        params=p, plant=Gd, closed_loop=cl, loop=L)


def build_force_tracking(cfg: Config, sensor: str | None = None) -> ForceTrackingParams:
    """Kernel constants of the designed force tracking (``design_force_tracking``); the sensor
    defaults to the one of ``cfg.tracking.law`` (``SENSOR_OF_LAW``)."""
    sensor = SENSOR_OF_LAW[cfg.tracking.law] if sensor is None else sensor
    return design_force_tracking(cfg, sensor).params
