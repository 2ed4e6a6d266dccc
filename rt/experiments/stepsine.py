"""Step-sine FRFs of the closed loop (SPEC section 6): amplitude-controlled, settled, per point.

The paper measures accelerance FRFs a(0.45 m) / F_exc around the resonances of modes 2..5 with
the excitation force amplitude held constant, by step-sine or by sweeps so slow (<= 0.1 Hz/s)
that they are a step-sine. For a nonlinear (friction) system the result depends on the force
amplitude and on the sweep direction, so both are parameters here and the direction is recorded.

One frequency point f (``settle_point``), from the previous point's final loop state:

    repeat, in blocks of whole periods (P = max(periods_per_block, ceil(min_block_s f)) periods):
        run the loop for one block at the commanded amplitude F_cmd        (rt.loop.driver.run, continued)
        X_a, X_F = first harmonics of a_frf and of the measured force F_exc  (``harmonics``)
        H_j = X_a / X_F  [(m/s^2)/N]                                       (complex: with phase)
        F_cmd <- F_cmd (F_target / |X_F|)^g, the factor limited to [1/s, s] (``update_amplitude``)
        settled if (``steady``) the remaining change of H predicted from the last 2N block
            estimates (geometric tail, Aitken) is below rel_tol, and the measured force of the
            last N blocks lies within amp_tol of the target
        give up (settled = False, reported, never dropped) before max_s of simulated time
    measure over the final N blocks: H, |X_a|, |X_F|, THD of a_frf, mean F_N1, actuator energy,
    and H_scatter, the relative std of their block estimates (the measurement's own spread)

Defaults (``Settle``) and why:

* blocks of >= 10 periods and >= 20 ms (135 ms at 74 Hz, 51 ms at 196 Hz, 20 ms at 616 Hz):
  long enough that the Hann-weighted fit separates the excitation frequency from the free
  vibration of the neighbouring lightly damped modes (mode 1 at 9.8 Hz, mode 2 near 70 Hz ring
  for seconds after every frequency step), short enough to follow a point's transient.
* Hann weighting of the least-squares fits: with a rectangular window the block estimates of |H|
  at the passive mode-3 peak (5 N, 196 Hz) scattered by 2.6 % (std) from leakage of that free
  vibration and of the unresolved contact-mode ringing above 6 kHz (raw a_frf RMS 920 m/s^2 against
  a 34 m/s^2 first harmonic); with Hann by 0.7 %. The fit stays exact for a periodic signal.
* the test on the predicted remaining change, not on the change per block: after a frequency
  step the stuck structure's barely damped free vibration (mode 3 at ~220 Hz once the damper
  sticks, bare-beam damping 0.1 %, decay time ~0.7 s) beats with the excitation; block estimates
  then change by < 1 % per block while H is still several percent off (a first version that
  compared window means settled at 205 and 215 Hz with 14-16 % scatter left).
* N = 3, rel_tol = 1 %: the paper's FRFs are read to a few percent; 2N = 6 blocks give the
  lag-1 ratio from four pairs of differences. At a friction-affected resonance the response is
  not exactly periodic (stick-slip varies from cycle to cycle; passive, 5 N, 196 Hz: H of 100 ms
  blocks scatters by ~1 % in magnitude and ~3 deg in phase for as long as it is run, 8 s tried),
  so such a point settles on the first block that changed by less than ~3 rel_tol, and reports
  its spread in H_scatter (Lyapunov near mode 3 at 5 N: 2-18 %; passive: 0.3-5 %).
* max_s = 8 s per point: the friction-damped modes 3..5 settle within 0.3-1 s at 5 N (passive:
  6-17 blocks); mode 2 barely slips and its peak points needed 2.6-6.0 s (17-44 blocks). A
  point that has not settled is measured over its final blocks anyway and flagged.
* amplitude control, log-domain integral (ratio) update with gain g = 1 and the factor limited
  to [1/2, 2]: g = 1 is exact in one update for a static force gain (any shaker away from
  resonance; the ideal force: the first update is already a no-op). With a shaker whose force
  drops out at resonance, the force first follows a command step (electrical feedthrough) and
  then drops as the response builds up, so a g = 1 update under-corrects and never overshoots;
  the limit keeps a single block (e.g. in a frequency step's transient) from kicking the
  structure with more than twice the force.

Sweeps (``sweep``; ``run_branch`` checks the input and builds the loop) run the points in the
given order, each from the previous point's final state (``frictionrt.rt.loop.driver.run(..., start=...)``: ticks
and every state continue). The excitation is F_cmd sin(2 pi f k dt) at the absolute tick k, so
its phase jumps at a frequency step, as in a step-sine without phase continuity; the detector
waits the transient out.

Slow continuous sweep (``slow_sweep``, the paper's <= 0.1 Hz/s sweeps): a staircase of
constant-frequency dwells whose steps are chosen so that the phase stays exactly continuous
((f' - f) t_b is a whole number at each step time t_b, ``phase_continuous_step``); each dwell is
one FRF point. Measured against the step-sine (passive, 5 N, mode 3, bandwidth ~5 Hz): up-sweep
peak 7.56 at 194.6 Hz (0.5 Hz/s) and 7.49 at 194.9 Hz (2 Hz/s); the step-sine continuing upwards
on a 1 Hz grid peaks at 7.77 at 193 Hz (the sweep lags: -3.6 %, 1.9 Hz late at 2 Hz/s); a
down-sweep follows the friction-softened branch to 11.4 at 189 Hz (the jump phenomenon of
a softening system). Through the stuck structure's 0.46 Hz wide mode-3 peak (F_N1 = 600 N) a
2 Hz/s sweep reads 92 instead of 161 (m/s^2)/N, 0.6 Hz late: the classical sweep distortion for
a rate above (bandwidth)^2; 0.1 % off the peak.

Parallel: the branches of several sweeps run in processes or on dask (rt/experiments/branches.py).

Length: the step-sine method in one place (harmonics, settling, amplitude control, sweeps up,
down and slow, the grids, the plot), with the measured figures in this docstring; the parallel
branch runners are rt/experiments/branches.py.
"""
from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import NamedTuple

import numpy as np

from frictionrt.plant.actuator import output_index as actuator_output_index
from frictionrt.rt.common.config import LAWS, Config
from frictionrt.rt.common.config import DEFAULT_ESTIMATOR, estimator_of
from frictionrt.rt.loop import Designs, Loop, LoopState, run

WINDOWS = ("rect", "hann")
SENSOR_READINGS = ("a_frf_meas", "a_tip_meas")  # accelerometer readings (plant.sensors) whose FRFs a point also gives


# --- harmonic analysis ------------------------------------------------------------------------

class Harmonics(NamedTuple):
    """Least-squares harmonics of a signal (``harmonics``); amplitudes in the signal's unit."""
    amp: float           # first-harmonic amplitude A_1
    phase_rad: float     # its phase phi_1 [rad]: x ~ A_1 cos(2 pi f t + phi_1), t = k dt
    thd: float           # total harmonic distortion sqrt(A_2^2 + ... + A_n^2) / A_1 [-]
    X: np.ndarray        # (n,) complex amplitudes X_h = A_h e^(i phi_h), h = 1..n (those below Nyquist)
    offset: float        # mean value c_0
    n_samples: int       # samples fitted (whole periods at the end of x)


def harmonics(x: np.ndarray, freq_hz: float, dt: float, n_harm: int = 5, *, k0: int = 0,
              window: str = "rect") -> Harmonics:
    """Harmonics 1..n_harm of x at the fundamental freq_hz [Hz], least squares over the whole
    periods at the end of x.

    Model, for the samples x_i at the ticks k0 + i (t_i = (k0 + i) dt [s], the loop's time base,
    so phases refer to t = 0 and blocks of one run share one reference):

        x_i ~ c_0 + sum_{h=1}^{n} Re(X_h e^{i h w t_i}),   w = 2 pi freq_hz,
        minimising  sum_i w_i (x_i - model_i)^2,  w_i = 1 ("rect") or a Hann window ("hann"),

    A_h = |X_h|, phi_h = arg X_h, THD = sqrt(sum_{h=2}^{n} A_h^2) / A_1. The fit is exact for a
    signal made of these harmonics (either window); Hann weighting suppresses the leakage of
    components at other frequencies (free vibration of other modes, broadband ringing).
    Harmonics at or above the Nyquist frequency 1/(2 dt) are left out of the fit and of the THD
    (thd is NaN when none of 2..n_harm lies below it).

    Parameters
    ----------
    x : samples, any unit; at least one period of freq_hz.
    freq_hz : fundamental [Hz], 0 < freq_hz < 1/(2 dt).
    dt : sample time [s].
    n_harm : highest harmonic fitted (>= 1).
    k0 : tick of x[0].
    window : "rect" or "hann".
    """
    return harmonics_of_columns(np.asarray(x, dtype=float)[:, None], freq_hz, dt, n_harm, k0=k0, window=window)[0]


def harmonics_of_columns(X: np.ndarray, freq_hz: float, dt: float, n_harm: int = 5, *, k0: int = 0,
                         window: str = "rect") -> list[Harmonics]:
    """``harmonics`` of each column of X (n, m): m signals of the same ticks, fitted on one
    design matrix. Each column is its own least-squares solve, bit for bit its ``harmonics``
    alone (a solve with m right-hand sides differs in the last bits); building the design
    matrix, half the cost of a block's fit, is done once."""
    X = np.asarray(X, dtype=float)
    nyq = 0.5 / dt
    if not (math.isfinite(freq_hz) and 0.0 < freq_hz < nyq):
        raise ValueError(f"freq_hz {freq_hz!r}: must lie in (0, {nyq:g}) Hz (below Nyquist)")
    if n_harm < 1:
        raise ValueError(f"n_harm {n_harm}: must be >= 1 (1 = first harmonic only)")
    if window not in WINDOWS:
        raise ValueError(f"window {window!r}: expected one of {', '.join(WINDOWS)}")
    per = 1.0 / (freq_hz * dt)                       # samples per period
    n_per = math.floor(len(X) / per)
    if n_per < 1:
        raise ValueError(f"x holds {len(X)} samples, less than one period of {freq_hz:g} Hz "
                         f"({per:.1f} samples): give at least {math.ceil(per)}")
    n = min(len(X), round(n_per * per))
    h = np.arange(1, n_harm + 1)
    h = h[h * freq_hz < nyq]
    k = np.arange(k0 + len(X) - n, k0 + len(X))
    wt = np.outer(k * dt, 2.0 * np.pi * freq_hz * h)  # h w t, as the loop computes w (k dt)
    A = np.column_stack([np.ones(n), np.cos(wt), np.sin(wt)])
    sw = np.sqrt(0.5 - 0.5 * np.cos(2.0 * np.pi * (np.arange(n) + 0.5) / n)) if window == "hann" else None
    if sw is not None:
        A = A * sw[:, None]
    m = len(h)
    out = []
    for j in range(X.shape[1]):
        y = X[-n:, j] if sw is None else X[-n:, j] * sw
        c, *_ = np.linalg.lstsq(A, y, rcond=None)
        Xh = c[1:1 + m] - 1j * c[1 + m:]              # a cos + b sin = Re((a - i b) e^{i wt})
        amps = np.abs(Xh)
        thd = float(np.sqrt(np.sum(amps[1:] ** 2)) / amps[0]) if m > 1 else float("nan")
        out.append(Harmonics(float(amps[0]), float(np.angle(Xh[0])), thd, Xh, float(c[0]), n))
    return out


# --- settling and amplitude control -----------------------------------------------------------

@dataclass(frozen=True)
class Settle:
    """Settings of the steady-state detector and the amplitude controller (defaults and their
    justification: module docstring)."""
    periods_per_block: int = 10    # whole periods per block, at least
    min_block_s: float = 0.02      # block length, at least [s]
    n_blocks: int = 3              # N: the detector looks at the last 2 N blocks, the measurement at the final N
    rel_tol: float = 0.01          # predicted remaining change of H, relative [-]
    max_s: float = 8.0             # simulated time per point before giving up [s]
    amp_tol: float = 0.01          # measured force amplitude within this of the target [-]
    amp_gain: float = 1.0          # g of the ratio update (0 < g <= 1)
    amp_step_max: float = 2.0      # largest factor of one update (> 1)
    window: str = "hann"           # weighting of the harmonic fits
    n_harm: int = 5                # harmonics fitted (THD of the response: 2..n_harm)

    def __post_init__(self):
        checks = [
            ("periods_per_block", self.periods_per_block >= 1, ">= 1"),
            ("min_block_s", self.min_block_s >= 0.0, ">= 0 s"),
            ("n_blocks", self.n_blocks >= 2, ">= 2 (a scatter needs two blocks)"),
            ("rel_tol", 0.0 < self.rel_tol < 1.0, "in (0, 1), e.g. 0.01"),
            ("max_s", self.max_s > 0.0, "> 0 s"),
            ("amp_tol", 0.0 < self.amp_tol < 1.0, "in (0, 1), e.g. 0.01"),
            ("amp_gain", 0.0 < self.amp_gain <= 1.0, "in (0, 1]"),
            ("amp_step_max", self.amp_step_max > 1.0, "> 1, e.g. 2"),
            ("window", self.window in WINDOWS, f"one of {', '.join(WINDOWS)}"),
            ("n_harm", self.n_harm >= 1, ">= 1"),
        ]
        for name, ok, allowed in checks:
            if not ok:
                raise ValueError(f"settle.{name} = {getattr(self, name)!r}: must be {allowed}")

    def block_ticks(self, freq_hz: float, dt: float) -> int:
        """Ticks of one block at freq_hz [Hz]: the nearest whole number to
        max(periods_per_block, ceil(min_block_s f)) periods."""
        periods = max(self.periods_per_block, math.ceil(self.min_block_s * freq_hz))
        return round(periods / (freq_hz * dt))

    def check(self, freqs_hz: Sequence[float], dt: float) -> None:
        """ValueError naming the frequency if max_s cannot hold the 2 N blocks the detector
        needs there."""
        for f in freqs_hz:
            need = 2 * self.n_blocks * self.block_ticks(f, dt) * dt
            if need > self.max_s:
                raise ValueError(f"{f:g} Hz: the detector needs 2 x {self.n_blocks} blocks = {need:.3g} s, "
                                 f"more than settle.max_s = {self.max_s:g} s; raise settle.max_s or lower "
                                 "settle.periods_per_block")


def update_amplitude(F_cmd: float, F_meas: float, F_target: float, gain: float = 1.0,
                     step_max: float = 2.0) -> float:
    """Next commanded force amplitude [N]: a log-domain integral (ratio) update

        F_cmd' = F_cmd * clip((F_target / F_meas)^gain, 1/step_max, step_max)

    F_meas [N] is the measured first harmonic of the force at the commanded F_cmd [N]. For a
    static force gain G (F_meas = G F_cmd) the log error e = ln(F_target / F_meas) shrinks by
    (1 - gain) per update: gain = 1 is exact in one update. A non-positive F_meas (no force
    measured) raises F_cmd by step_max."""
    if F_meas <= 0.0:
        return F_cmd * step_max
    return F_cmd * min(max((F_target / F_meas) ** gain, 1.0 / step_max), step_max)


def steady(H: Sequence[complex], n_blocks: int, rel_tol: float) -> tuple[bool, float]:
    """Steady-state test on the block estimates H (oldest first); returns (settled, residual).

    A decaying free vibration projects onto equal blocks as a geometric sequence: with blocks
    of T_b, H_j = H_inf + c q^j, q = e^{(-sigma + i (w_n - w)) T_b}, exactly for a linear system.
    From the differences D_j = H_j - H_{j-1} of the last 2 n_blocks estimates:

        q = sum_j D_j conj(D_{j-1}) / sum_j |D_{j-1}|^2            (lag-1 ratio, complex)
        residual = |D_last| |q| / |1 - q| / |mean of the last n_blocks H|
                 = |H_inf - H_last| / |H| predicted by the geometric tail (Aitken)
        settled  if  |q| < 1  and  residual <= rel_tol

    A slow decay (|q| near 1) or a beat (q's angle) is waited out however small the change per
    block. A response that is not exactly periodic (stick-slip differs from cycle to cycle) has
    uncorrelated block estimates, q ~ -1/2, residual ~ |D_last| / 3: it settles on the first
    block that changed by less than ~3 rel_tol; its scatter is reported (``Point.H_scatter``).
    Fewer than 2 n_blocks estimates: (False, inf)."""
    if len(H) < 2 * n_blocks:
        return False, float("inf")
    h = np.asarray(H[-2 * n_blocks:], dtype=complex)
    D = np.diff(h)
    den = np.sum(np.abs(D[:-1]) ** 2)
    m = abs(h[-n_blocks:].mean())
    if den == 0.0:  # no change at all (a periodic response to round-off)
        return True, 0.0
    q = np.sum(D[1:] * np.conj(D[:-1])) / den
    if abs(q) >= 1.0 or m == 0.0:
        return False, float("inf")
    residual = float(abs(D[-1]) * abs(q) / abs(1.0 - q) / m)
    return residual <= rel_tol, residual


# --- one frequency point ----------------------------------------------------------------------

@dataclass
class Point:
    """One settled (or given-up) frequency point; the measurement is over the final N blocks."""
    freq_hz: float
    H: complex            # accelerance X_a / X_F [(m/s^2)/N]
    a_amp: float          # first harmonic of a_frf [m/s^2]
    F_amp: float          # first harmonic of the measured force F_exc [N]
    F_cmd: float          # commanded force amplitude at the end [N]
    thd: float            # THD of a_frf (harmonics 2..n_harm) [-]
    F_N1_mean: float      # mean adaptive screw force [N]
    energy_j: float       # actuator energy used during the measurement blocks [J]
    settle_s: float       # simulated time at this frequency [s]
    settled: bool
    n_blocks: int         # blocks run at this frequency
    H_scatter: float      # relative std of the final blocks' H [-]
    residual: float       # the detector's last predicted remaining change of H [-]
    k_start: int          # first tick at this frequency
    k_end: int            # the next tick (the final state's k)
    H_blocks: np.ndarray = field(repr=False)      # (n_blocks,) complex H per block
    F_meas_blocks: np.ndarray = field(repr=False)  # (n_blocks,) measured force per block [N]
    F_cmd_blocks: np.ndarray = field(repr=False)   # (n_blocks,) commanded force per block [N]
    drive_amp: float = math.nan    # first harmonic of the drive (the commands of the final N blocks) [N]
    R_exc: complex = complex(math.nan)  # driving-point receptance w_exc / F_exc [m/N] (the plant's truth; w of
    #                                     row k is at t_k+1, the force held over the tick: w referred to its middle)
    H_sensors: dict = field(default_factory=dict, repr=False)  # a_frf_meas, a_tip_meas readings / F_exc
    tick_s: float = 0.0   # the ticks' execution times at this frequency, summed (the log's tick_ns) [s]


def _run_block(loop: Loop, freq_hz: float, F_cmd: float, n: int, state: LoopState | None, seed: int | None,
               window: str, controller=None):
    """Run n ticks at freq_hz [Hz] and force command F_cmd [N] from state (in this thread: no
    thread start per block) with ``controller`` (``run``'s; None: the numba controller); returns
    the run, the tick of its first row and the first harmonics X_a [m/s^2], X_F [N] of a_frf and
    F_exc."""
    dt = loop.cfg.dt_s
    r = run(loop, freq_hz, F_cmd, n * dt, start=state, seed=seed, in_thread=False, controller=controller)
    k0 = r.final.k - len(r.log)
    h_a, h_F = harmonics_of_columns(r.log[:, [loop.column("a_frf"), loop.column("F_exc")]], freq_hz, dt, 1,
                                    k0=k0, window=window)
    return r, k0, h_a.X[0], h_F.X[0]


def settle_point(loop: Loop, freq_hz: float, amp_n: float, *, start: LoopState | None = None,
                 settle: Settle = Settle(), seed: int | None = None, controller=None) -> tuple[Point, LoopState]:
    """Run the loop at freq_hz [Hz] with the measured force amplitude held at amp_n [N] until
    steady (module docstring); returns the point and the final loop state (the next point's start).

    start: the state to continue from (None: at rest, noise seeded with seed or rt.seed).
    controller: the loop's controller (``frictionrt.rt.loop.driver.run``'s; None: the numba controller)."""
    dt = loop.cfg.dt_s
    n = settle.block_ticks(freq_hz, dt)
    N = settle.n_blocks
    iE = actuator_output_index()["E"]
    state = start
    F_cmd = float(amp_n)  # float: the compiled loop is specialised on its argument types
    H, F_meas, F_cmds, tail = [], [], [], []  # tail: (k0, the block's columns cols, E before, F_cmd) of the final N
    cols = [loop.column(name) for name in ("a_frf", "F_exc", "F_N1", f"w_{loop.cfg.plant.excitation_point}",
                                           *SENSOR_READINGS)]
    k_start = 0 if start is None else start.k
    settled, residual = False, float("inf")
    tick_ns = 0.0
    while True:
        E_before = 0.0 if state is None else float(state.ya[iE])
        r, k0, X_a, X_F = _run_block(loop, freq_hz, F_cmd, n, state, seed, settle.window, controller)
        state = r.final
        tick_ns += float(r.signal("tick_ns").sum())
        H.append(X_a / X_F)
        F_meas.append(abs(X_F))
        F_cmds.append(F_cmd)
        tail = (tail + [(k0, r.log[:, cols], E_before, F_cmd)])[-N:]
        E_end = float(r.signal("E")[-1])
        F_cmd = update_amplitude(F_cmd, abs(X_F), amp_n, settle.amp_gain, settle.amp_step_max)
        held = all(abs(f / amp_n - 1.0) <= settle.amp_tol for f in F_meas[-N:])
        settled, residual = steady(H, N, settle.rel_tol)
        settled = settled and held
        if settled or (state.k - k_start + n) * dt > settle.max_s:  # the next block would pass max_s
            break
    T = np.concatenate([b[1] for b in tail])  # a_frf, F_exc, F_N1, w_exc, SENSOR_READINGS over the final N
    ha = harmonics(T[:, 0], freq_hz, dt, settle.n_harm, k0=tail[0][0], window=settle.window)
    drive = np.concatenate([b[3] * np.sin(2 * np.pi * freq_hz * dt * (b[0] + np.arange(len(b[1])))) for b in tail])
    hF, h_drive, h_w, *h_meas = harmonics_of_columns(np.column_stack([T[:, 1], drive, T[:, 3:]]), freq_hz, dt, 1,
                                                     k0=tail[0][0], window=settle.window)
    h_last = np.asarray(H[-N:])
    scatter = float(np.sqrt(np.mean(np.abs(h_last - h_last.mean()) ** 2)) / abs(h_last.mean()))
    point = Point(freq_hz=float(freq_hz), H=complex(ha.X[0] / hF.X[0]), a_amp=ha.amp, F_amp=hF.amp,
                  F_cmd=float(F_cmds[-1]), thd=ha.thd,
                  F_N1_mean=float(np.mean(np.ascontiguousarray(T[:, 2]))),  # contiguous: the same pairwise sum
                  energy_j=E_end - tail[0][2], settle_s=(state.k - k_start) * dt, settled=settled,
                  n_blocks=len(H), H_scatter=scatter, residual=residual, k_start=k_start, k_end=state.k,
                  H_blocks=np.asarray(H), F_meas_blocks=np.asarray(F_meas), F_cmd_blocks=np.asarray(F_cmds),
                  drive_amp=abs(h_drive.X[0]), R_exc=complex(h_w.X[0] / hF.X[0] * np.exp(-1j * np.pi * freq_hz * dt)),
                  H_sensors={name: complex(h.X[0] / hF.X[0]) for h, name in zip(h_meas, SENSOR_READINGS)},
                  tick_s=tick_ns * 1e-9)
    return point, state


# --- sweeps -----------------------------------------------------------------------------------

@dataclass
class StepSineResult:
    """A step-sine FRF: one entry per frequency point, in the order measured (SI units)."""
    law: str
    estimator: str
    amp_n: float                # target force amplitude [N]
    direction: str              # "up", "down" (monotonic frequencies) or "given" (any other order)
    settle: Settle
    freq_hz: np.ndarray         # [Hz]
    H: np.ndarray               # complex accelerance a(0.45 m) / F_exc [(m/s^2)/N]
    a_amp: np.ndarray           # first harmonic of the acceleration at 0.45 m [m/s^2]
    F_amp: np.ndarray           # first harmonic of the measured force [N]
    F_cmd: np.ndarray           # commanded force amplitude at the end of each point [N]
    thd: np.ndarray             # THD of the response [-]
    F_N1_mean: np.ndarray       # [N]
    energy_j: np.ndarray        # actuator energy during the measurement blocks [J]
    settle_s: np.ndarray        # simulated time per point [s]
    settled: np.ndarray         # bool
    n_blocks: np.ndarray        # blocks per point
    H_scatter: np.ndarray       # relative std of the final blocks' H [-]
    residual: np.ndarray        # the detector's last predicted remaining change of H [-]
    k_start: np.ndarray         # first tick of each point
    k_end: np.ndarray           # tick after each point (the next point's k_start)
    drive_amp: np.ndarray | None = None  # first harmonic of the drive [N] (= F_amp with an ideal source)
    R_exc: np.ndarray | None = None      # complex driving-point receptance w_exc / F_exc [m/N] (plant truth)
    H_sensors: dict | None = None        # {a_frf_meas, a_tip_meas: complex reading / F_exc [(m/s^2)/N]}
    tick_s: np.ndarray | None = None     # the ticks' execution times per point, summed [s] (not in to_dict: a timing)

    @property
    def H_abs(self) -> np.ndarray:
        """|H| [(m/s^2)/N]."""
        return np.abs(self.H)

    @property
    def phase_rad(self) -> np.ndarray:
        """arg H [rad], in (-pi, pi]."""
        return np.angle(self.H)

    def to_dict(self) -> dict:
        """Plain JSON types; H as H_re, H_im, plus H_abs and phase_rad."""
        d = {"law": self.law, "estimator": self.estimator, "amp_n": self.amp_n, "direction": self.direction,
             "settle": asdict(self.settle), "H_re": self.H.real.tolist(), "H_im": self.H.imag.tolist(),
             "H_abs": self.H_abs.tolist(), "phase_rad": self.phase_rad.tolist()}
        for name in ("freq_hz", "a_amp", "F_amp", "F_cmd", "thd", "F_N1_mean", "energy_j", "settle_s",
                     "settled", "n_blocks", "H_scatter", "residual", "k_start", "k_end"):
            d[name] = getattr(self, name).tolist()
        d["thd"] = [None if math.isnan(v) else v for v in d["thd"]]
        if self.drive_amp is not None:
            d["drive_amp"] = self.drive_amp.tolist()
        return d


def sweep_direction(freqs_hz: Sequence[float]) -> str:
    """"up" for increasing, "down" for decreasing frequencies, else "given"."""
    d = np.diff(np.asarray(freqs_hz, dtype=float))
    return "up" if np.all(d > 0) else "down" if np.all(d < 0) else "given"


def check_sweep(cfg: Config, law: str, freqs_hz: Sequence[float], amp_n: float, settle: Settle,
                estimator: str = DEFAULT_ESTIMATOR) -> None:
    """ValueError naming the bad value and the fix, before anything runs."""
    nyq = 0.5 / cfg.dt_s
    if law not in LAWS:
        raise ValueError(f"law {law!r}: expected one of {', '.join(LAWS)}")
    estimator_of(estimator)
    if not (math.isfinite(amp_n) and amp_n > 0.0):
        raise ValueError(f"amplitude {amp_n!r} N: an FRF needs a finite force amplitude > 0 N")
    if len(freqs_hz) == 0:
        raise ValueError("no frequencies: give at least one, e.g. 190,195,200")
    for f in freqs_hz:
        if not (math.isfinite(f) and 0.0 < f < nyq):
            raise ValueError(f"frequency {f!r} Hz: must lie in (0, {nyq:g}) Hz (below the Nyquist frequency)")
    settle.check(freqs_hz, cfg.dt_s)


def sweep(loop: Loop, freqs_hz: Sequence[float], amp_n: float, *, start: LoopState | None = None,
          settle: Settle = Settle(), seed: int | None = None,
          progress: Callable[[int], object] | None = None, controller=None) -> StepSineResult:
    """Step-sine FRF of a built loop at the force amplitude amp_n [N], the points in the order of
    freqs_hz [Hz], each continuing from the previous one's final state (``run_branch`` checks the
    input and builds the loop).

    start: the first point's start state (None: at rest, noise seeded with seed, default
    rt.seed). progress(1) is called after each point. controller: the loop's controller
    (``settle_point``)."""
    freqs = [float(f) for f in freqs_hz]
    settle.check(freqs, loop.cfg.dt_s)
    points = []
    state = start
    for f in freqs:
        p, state = settle_point(loop, f, amp_n, start=state, settle=settle, seed=seed, controller=controller)
        points.append(p)
        if progress is not None:
            progress(1)
    col = lambda name, dtype=float: np.array([getattr(p, name) for p in points], dtype=dtype)
    return StepSineResult(law=loop.law, estimator=loop.estimator, amp_n=float(amp_n),
                          direction=sweep_direction(freqs), settle=settle, freq_hz=col("freq_hz"),
                          H=col("H", complex), a_amp=col("a_amp"), F_amp=col("F_amp"), F_cmd=col("F_cmd"),
                          thd=col("thd"), F_N1_mean=col("F_N1_mean"), energy_j=col("energy_j"),
                          settle_s=col("settle_s"), settled=col("settled", bool), n_blocks=col("n_blocks", np.int64),
                          H_scatter=col("H_scatter"), residual=col("residual"), k_start=col("k_start", np.int64),
                          k_end=col("k_end", np.int64), drive_amp=col("drive_amp"), R_exc=col("R_exc", complex),
                          H_sensors={name: np.array([p.H_sensors[name] for p in points]) for name in SENSOR_READINGS},
                          tick_s=col("tick_s"))


def phase_continuous_step(f_hz: float, k_b: int, dt: float, rate_hz_s: float, block_s: float) -> tuple[float, int]:
    """The next frequency [Hz] and its dwell [ticks] of a slow sweep at the boundary tick k_b.

    The loop's excitation is F sin(2 pi f k dt) at the absolute tick k, so a step from f to f' at
    k_b keeps the phase exactly continuous iff (f' - f) k_b dt is a whole number n (mod 2 pi):
    f' = f + sign(rate) n / t_b, t_b = k_b dt, with n = max(1, round(|rate| block_s t_b)), held for
    n / (|rate| t_b) s, so that the mean rate is rate_hz_s [Hz/s] and the dwell is about block_s
    once t_b >= 1 / (|rate| block_s) (before that: fewer, larger steps of 1 / t_b, longer dwells)."""
    t_b = k_b * dt
    n = max(1, round(abs(rate_hz_s) * block_s * t_b))
    step = math.copysign(n / t_b, rate_hz_s)
    return f_hz + step, max(1, round(n / (abs(rate_hz_s) * t_b) / dt))


def slow_sweep(loop: Loop, f_start_hz: float, f_end_hz: float, amp_n: float, rate_hz_s: float, *,
               block_s: float = 0.1, step_max_hz: float = 0.25, start: LoopState | None = None,
               settle: Settle = Settle(), seed: int | None = None,
               progress: Callable[[int], object] | None = None, controller=None) -> StepSineResult:
    """A slow continuous sweep (the paper's <= 0.1 Hz/s sweeps) from f_start_hz to f_end_hz [Hz]
    at |rate_hz_s| [Hz/s], force amplitude held at amp_n [N]; one FRF point per dwell.

    The excitation's phase is exactly continuous (``phase_continuous_step``): a staircase of
    constant-frequency dwells whose steps shrink as time runs, never larger than step_max_hz. A
    lead-in dwell at f_start_hz lasts until t = 1 / step_max_hz (4 s by default, counted from the
    run's start; also the structure's settling at the first frequency) and is not a point. Each
    dwell is measured as a step-sine block is (first harmonics, Hann weighting, THD) and updates
    the force command as the amplitude controller does. A sweep point is quasi-stationary by
    construction: settled is True, H_scatter and residual NaN. Returns a ``StepSineResult``
    (direction "up" or "down"). controller: the loop's controller (``settle_point``)."""
    dt = loop.cfg.dt_s
    for name, v in (("rate", rate_hz_s), ("block_s", block_s), ("step_max_hz", step_max_hz)):
        if not (math.isfinite(v) and v != 0.0 and (name == "rate" or v > 0.0)):
            raise ValueError(f"slow sweep: {name} {v!r} must be a finite non-zero number (block and step > 0)")
    if (f_end_hz - f_start_hz) * rate_hz_s <= 0.0:
        raise ValueError(f"slow sweep from {f_start_hz:g} to {f_end_hz:g} Hz: the rate {rate_hz_s:g} Hz/s has "
                         "the wrong sign or the range is empty")
    check_sweep(loop.cfg, loop.law, [f_start_hz, f_end_hz], amp_n, Settle(max_s=1e9), loop.estimator)
    iE = actuator_output_index()["E"]
    state, f, F_cmd = start, float(f_start_hz), float(amp_n)
    k0 = 0 if start is None else start.k
    lead = max(round(1.0 / (step_max_hz * dt)) - k0, round(1.0 / (f * dt)))
    r, *_ = _run_block(loop, f, F_cmd, lead, state, seed, settle.window, controller)
    state = r.final
    lead_tick_ns = float(r.signal("tick_ns").sum())  # the lead-in's ticks count with the first point's
    rows = []
    while True:
        f, n = phase_continuous_step(f, state.k, dt, rate_hz_s, block_s)
        if (f - f_end_hz) * rate_hz_s > 0.0:
            break
        n = max(n, math.ceil(1.0 / (f * dt)))   # at least one period to fit
        E_before = float(state.ya[iE])
        r, kb, X_a, X_F = _run_block(loop, f, F_cmd, n, state, seed, settle.window, controller)
        state = r.final
        ha = harmonics(r.signal("a_frf"), f, dt, settle.n_harm, k0=kb, window=settle.window)
        rows.append(dict(freq_hz=f, H=X_a / X_F, a_amp=abs(X_a), F_amp=abs(X_F), F_cmd=F_cmd, thd=ha.thd,
                         F_N1_mean=float(np.mean(r.signal("F_N1"))), energy_j=float(state.ya[iE]) - E_before,
                         settle_s=n * dt, k_start=kb, k_end=state.k, tick_s=(float(r.signal("tick_ns").sum()) + lead_tick_ns) * 1e-9))
        lead_tick_ns = 0.0
        F_cmd = update_amplitude(F_cmd, abs(X_F), amp_n, settle.amp_gain, settle.amp_step_max)
        if progress is not None:
            progress(1)
    col = lambda name, dtype=float: np.array([row[name] for row in rows], dtype=dtype)
    m = len(rows)
    return StepSineResult(law=loop.law, estimator=loop.estimator, amp_n=float(amp_n),
                          direction="up" if rate_hz_s > 0 else "down", settle=settle, freq_hz=col("freq_hz"),
                          H=col("H", complex), a_amp=col("a_amp"), F_amp=col("F_amp"), F_cmd=col("F_cmd"),
                          thd=col("thd"), F_N1_mean=col("F_N1_mean"), energy_j=col("energy_j"),
                          settle_s=col("settle_s"), settled=np.ones(m, bool), n_blocks=np.ones(m, np.int64),
                          H_scatter=np.full(m, np.nan), residual=np.full(m, np.nan),
                          k_start=col("k_start", np.int64), k_end=col("k_end", np.int64), tick_s=col("tick_s"))


# --- frequency grids --------------------------------------------------------------------------

def mode_bands_hz(cfg: Config, modes: Sequence[int] = (2, 3, 4, 5),
                  designs: Designs | None = None, structure=None) -> dict[int, tuple[float, float]]:
    """Per bending mode (1 = first): (f_slip, f_stuck) [Hz], the eigenfrequencies of the plant
    linearised about its preloaded state (the pairs the screws close, at the configured F_N1)

    * f_stuck: those pairs stuck (``frictionrt.plant.model.stuck_frequencies_hz(model, preloaded_pairs)``;
      index i is mode i + 1),
    * f_slip: the same with the pairs in the adaptive screw's pressure cone free to slide
      tangentially (normal contact kept; ``frictionrt.plant.modes.sliding_joint_hz``).

    A friction-affected resonance lies near f_slip or between the two (docs/experiments.md).
    designs: the study's shared designs (``frictionrt.rt.loop.Designs``: the plant its loops use; None:
    built here). structure: an imported structure (``frictionrt.rt.loop.structure.Structure``) instead
    of the configured beams (``structure_mode_bands_hz``; its modes counted among those the laws act on)."""
    from frictionrt.plant.model import preloaded_pairs, stuck_frequencies_hz
    from frictionrt.plant.modes import sliding_joint_hz
    if structure is not None:
        return structure_mode_bands_hz(cfg, (Designs() if designs is None else designs).plant(cfg, structure), modes)
    model = (Designs() if designs is None else designs).plant(cfg)
    f_stuck = stuck_frequencies_hz(model, preloaded_pairs(model))
    f_slip = sliding_joint_hz(model)
    for m in modes:
        if not 1 <= m <= min(len(f_stuck), len(f_slip)):
            raise ValueError(f"mode {m}: the model has bending modes 1..{min(len(f_stuck), len(f_slip))}")
    return {m: (float(f_slip[m - 1]), float(f_stuck[m - 1])) for m in modes}


FRF_RESIDUE = 1e-2   # a mode the FRF shows: its accelerance residue >= this x the largest (structure_mode_bands_hz)


def structure_mode_bands_hz(cfg: Config, plant, modes: Sequence[int] = (2, 3, 4, 5)) -> dict[int, tuple[float, float]]:
    """``mode_bands_hz`` of an imported structure (``frictionrt.plant.se_plant.SEPlant``): per mode
    m (1 = first) the (f_slip, f_stuck) [Hz] of the m-th mode the laws act on, the plant linearised
    about its static equilibrium at its rest force F_N1 (``SEPlant.F_N1_initial``, the actuator's F0):

    * f_stuck: the closed points stuck (k_n on the normal gap, k_t on each tangential one),
    * f_slip: the same with the closed points at the adaptive bolt
      (``frictionrt.observer.model.adaptive_points``) free to slide tangentially (normal spring kept).

    The modes counted are those the laws act on and the FRF shows: u_rel participation |t phi_i| at
    least ``frictionrt.observer.model.LAW_PARTICIPATION`` x the largest among the computed modes (the
    observer's own criterion) and a residue of the accelerance a_frf / F_exc, |s_frf phi_i| |b_exc phi_i|,
    at least ``FRF_RESIDUE`` x the largest. A 3-D structure's lateral bending and torsion modes, which
    a vertical excitation barely drives (residue <= 3e-3 of the largest on the 3-D reference coarsened
    to 4-8 points, where the clusters' asymmetry couples them to u_rel), are not counted, so mode m is
    the m-th bending mode as on the built-in beams. With no closed point at the adaptive bolt at that
    force, f_slip = f_stuck. ValueError for a mode beyond those found."""
    import scipy.linalg as sla

    from frictionrt.observer.model import LAW_PARTICIPATION, adaptive_points
    p = plant.params
    d = 1 + p.nt
    closed, at = adaptive_points(cfg, plant, plant.F_N1_initial)
    t = p.S[-1]   # u_rel's row in the plant's coordinates (the last output row of S)
    s_frf = p.S[list(plant.se.sensor_names).index("frf")]
    n_eig = min(len(p.omega2), max(4 * max(modes) + 20, 40))

    def law_modes(free: np.ndarray) -> np.ndarray:
        kc = np.zeros(p.G.shape[0])
        kc[0::d] = p.k_n * closed
        for a in range(1, d):
            kc[a::d] = p.k_t * (closed & ~free)
        lam, V = sla.eigh(np.diag(p.omega2) + (p.G.T * kc) @ p.G, subset_by_index=[0, n_eig - 1])
        part = np.abs(t @ V)
        res = np.abs(s_frf @ V) * np.abs(p.b_exc @ V)
        f = np.sqrt(np.maximum(lam, 0.0)) / (2 * np.pi)
        return f[(part >= LAW_PARTICIPATION * part.max()) & (res >= FRF_RESIDUE * res.max()) & (f > 1e-3)]

    f_stuck = law_modes(np.zeros_like(closed))
    f_slip = law_modes(at)
    top = min(len(f_stuck), len(f_slip))
    for m in modes:
        if not 1 <= m <= top:
            raise ValueError(f"mode {m}: the imported structure has bending modes 1..{top} the laws act on "
                             f"(among its lowest {n_eig} modes)")
    return {m: (float(min(f_slip[m - 1], f_stuck[m - 1])), float(f_stuck[m - 1])) for m in modes}


def resonance_grid(centres_hz: Sequence[float], half_width_rel: float = 0.15, n_per_peak: int = 31) -> np.ndarray:
    """Frequencies [Hz], increasing: n_per_peak evenly spaced points over fc (1 -/+ half_width_rel)
    around each centre fc [Hz], merged (points of overlapping bands closer than half the finer
    spacing are dropped).

    Defaults: +/-15 % around the middle of a mode's (f_slip, f_stuck) band (``mode_bands_hz``;
    mode 3: 211 Hz) reaches from below the passive 20 N peak (< 190 Hz) to 8 % above f_stuck;
    31 points give 1 % steps, enough for the friction-damped peaks of modes 3-5; mode 2 barely
    slips and its peak is narrower (passive 5 N: |H| 30 at 70.3 Hz, 8.5 at 68.1 Hz): resolve it
    with more points or explicit frequencies."""
    c = np.asarray(centres_hz, dtype=float)
    if len(c) == 0 or not np.all(np.isfinite(c) & (c > 0)):
        raise ValueError(f"centres_hz {list(centres_hz)}: give at least one positive frequency [Hz]")
    if not 0.0 < half_width_rel < 1.0:
        raise ValueError(f"half_width_rel {half_width_rel!r}: must lie in (0, 1), e.g. 0.1")
    if n_per_peak < 2:
        raise ValueError(f"n_per_peak {n_per_peak}: must be >= 2")
    pts = np.sort(np.concatenate([fc * (1.0 + np.linspace(-half_width_rel, half_width_rel, n_per_peak))
                                  for fc in c]))
    step = 2.0 * half_width_rel * pts / (n_per_peak - 1)  # local spacing of the band a point came from (<=)
    keep = [0]
    for i in range(1, len(pts)):
        if pts[i] - pts[keep[-1]] >= 0.5 * min(step[i], step[keep[-1]]):
            keep.append(i)
    return pts[keep]


# --- plot -------------------------------------------------------------------------------------

def plot_frfs(results: Sequence[StepSineResult], path: str | None = None):
    """|H| [dB re 1 (m/s^2)/N] and phase [deg] against frequency, one curve per result (law,
    amplitude, direction); unsettled points hollow. Lines break where the frequency step exceeds
    three times the median step (between the bands of a resonance grid). PNG."""
    from matplotlib.figure import Figure
    fig = Figure(figsize=(9, 6.5))
    (ax_m, ax_p) = fig.subplots(2, 1, sharex=True)
    for r in results:
        order = np.argsort(r.freq_hz)
        f, H, ok = r.freq_hz[order], r.H[order], r.settled[order]
        df = np.diff(f)
        gap = np.nonzero(df > 3.0 * np.median(df))[0] + 1 if len(f) > 2 else np.array([], int)
        label = f"{r.law}, {r.amp_n:g} N, {r.direction}"
        line, = ax_m.plot(np.insert(f, gap, np.nan), np.insert(20 * np.log10(np.abs(H)), gap, np.nan),
                          lw=1.0, marker=".", ms=4, label=label)
        ax_p.plot(np.insert(f, gap, np.nan), np.insert(np.degrees(np.angle(H)), gap, np.nan), lw=1.0,
                  marker=".", ms=4, color=line.get_color())
        if not np.all(ok):
            ax_m.plot(f[~ok], 20 * np.log10(np.abs(H[~ok])), "o", mfc="none", color=line.get_color(), ms=7)
            ax_p.plot(f[~ok], np.degrees(np.angle(H[~ok])), "o", mfc="none", color=line.get_color(), ms=7)
    ax_m.set_ylabel("|H| = |a(0.45 m) / F_exc|\n[dB re 1 (m/s^2)/N]")
    ax_p.set_ylabel("phase [deg]")
    ax_p.set_yticks([-180, -90, 0, 90, 180])
    ax_p.set_xlabel("f [Hz]")
    ax_m.set_title("step-sine accelerance FRF, force amplitude held (hollow: not settled)")
    for ax in (ax_m, ax_p):
        ax.grid(True, lw=0.3)
    ax_m.legend(fontsize=8)
    fig.tight_layout()
    if path is not None:
        fig.savefig(path, dpi=110)
    return fig
