"""The one typed configuration of frictionrt: frozen dataclasses with the SPEC defaults.

Every physical parameter, gain and assumption lives here, in SI units. A configuration is
resolved from the defaults, then an optional TOML file (``--config FILE``), then
``--set key=value`` overrides, and validated once. Lists of named tables (beams, screws,
points) are addressed by their ``name`` in ``--set`` keys, e.g.
``--set plant.screws.adaptive.F_N=200``.

Each numeric field carries its unit and allowed range in its metadata; ``validate`` refuses
values outside it with a message that names the key, the value and the range.

Length: the one typed configuration of the project (every physical parameter, gain and
assumption with its SPEC default, unit and bounds) is kept in one file on purpose, so that a
reader finds every parameter in one place; the loading and override code is a third of it.
"""
from __future__ import annotations

import copy
import dataclasses
import enum
import functools
import math
import tomllib
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, get_args, get_origin, get_type_hints


LAWS = ("passive", "hysteresis", "lyapunov")


class Estimator(enum.StrEnum):
    """What the laws run on: the estimate of u_rel [m] and v_rel [m/s] at the adaptive screw.

    ``OBSERVER``: the paper's Kalman-designed nonlinear observer on the tip accelerometer and the
    force cell (docs/observer.md), the default everywhere; ``ORACLE``: the plant's own u_rel,
    v_rel, band-limited (the upper bound a perfect estimate gives); ``AMPLITUDE``: the paper's
    observer with each mode's frequency following that mode's amplitude (observer/amplitude.py,
    docs/observer.md). Members are strings, so ``Estimator.OBSERVER == "observer"``."""
    OBSERVER = "observer"
    ORACLE = "oracle"
    AMPLITUDE = "amplitude"


ESTIMATORS = (Estimator.OBSERVER.value, Estimator.ORACLE.value)   # the reproduction's pair: the default first
ALL_ESTIMATORS = tuple(e.value for e in Estimator)                # every kind (what --estimator accepts)
OBSERVERS = (Estimator.OBSERVER.value, Estimator.AMPLITUDE.value)  # the kinds that run an observer (state z)
DEFAULT_ESTIMATOR = Estimator.OBSERVER


def estimator_of(value) -> Estimator:
    """``value`` ("observer", "oracle", "amplitude" or an ``Estimator``) as an ``Estimator``;
    ValueError naming the choices otherwise."""
    try:
        return Estimator(value)
    except ValueError:
        raise ValueError(f"estimator {value!r}: give one of {', '.join(ALL_ESTIMATORS)}") from None
PASSIVE_MODES = ("voltage", "tracking")
MODEL_FORM_MODES = ("auto", "always", "never")   # diagnosis.model_form: when the model-form candidates are tried
AMPLIFIERS = ("current", "voltage")   # shaker.amplifier: the power amplifier's mode (plant/shaker.py)
# the plant's time step (plant.newmark): the trapezoidal rule with the discrete-gradient normal impulse
# (default), or generalized-alpha (Chung & Hulbert 1993) with its spectral radius plant.step_rho_inf
STEP_SCHEMES = ("trapezoidal", "generalized_alpha")
# the contact points' layout (plant.interface.layout; plant/layout.py): hand = pitch_m with the ends
# refined over end_zone_m; model = as many points, placed by the stuck pressure and slip onset; fronts = as
# many points, the ends' spacing over the closed contact and the open interface's points at the slip fronts
LAYOUTS = ("hand", "model", "fronts")
INT64 = (-2**63, 2**63 - 1)   # integer fields reach the kernels as int64


class ConfigError(ValueError):
    """A bad configuration value or file; the message names the key, the value and the fix."""


def param(default, unit: str = "", lo: float | None = None, hi: float | None = None,
          lo_inclusive: bool = True, doc: str = ""):
    """A configuration field with a unit and an allowed range [lo, hi] (lo open if not inclusive)."""
    meta = {"unit": unit, "lo": lo, "hi": hi, "lo_inclusive": lo_inclusive, "doc": doc}
    if isinstance(default, (list, tuple)) or dataclasses.is_dataclass(default):
        return field(default_factory=lambda d=default: d, metadata=meta)
    return field(default=default, metadata=meta)


# --- structure description (SPEC section 1) -------------------------------------------------

@dataclass(frozen=True)
class Beam:
    """A straight beam along x, rectangular section, neutral axis at height z0."""
    name: str
    x0_m: float = param(0.0, "m", doc="x of the beam's left end")
    length_m: float = param(0.775, "m", lo=0.0, lo_inclusive=False)
    width_m: float = param(0.040, "m", lo=0.0, lo_inclusive=False)
    height_m: float = param(0.008, "m", lo=0.0, lo_inclusive=False)
    z0_m: float = param(0.0, "m", doc="height of the neutral axis")
    E: float = param(210e9, "Pa", lo=0.0, lo_inclusive=False, doc="Young's modulus")
    rho: float = param(7850.0, "kg/m^3", lo=0.0, lo_inclusive=False, doc="density")
    nu: float = param(0.3, "-", lo=0.0, hi=0.5,
                      doc="Poisson's ratio (A); not used by Euler-Bernoulli elements (sets the "
                          "Mindlin ratio quoted for k_t/k_n)")


@dataclass(frozen=True)
class Clamp:
    """The displacements of `beam` fixed at x; its rotation fixed too, or held by a rotational
    spring of compliance rot_compliance (1 / stiffness); its transverse displacement w fixed too, or
    held by a translational spring of compliance trans_compliance."""
    beam: str
    x_m: float = param(0.0, "m")
    rot_compliance_rad_per_Nm: float = param(0.0, "rad/(N m)", lo=0.0,
                                             doc="rotational compliance of the fixture; 0: rigid (A)")
    trans_compliance_m_per_N: float = param(0.0, "m/N", lo=0.0,
                                            doc="transverse (w) compliance of the fixture; 0: rigid (A)")


@dataclass(frozen=True)
class Screw:
    """A screw pressing `upper` onto `lower` of the interface at x with normal force F_N."""
    name: str
    x_m: float = param(0.475, "m")
    F_N: float = param(6000.0, "N", lo=0.0, doc="clamping force (initial value if adaptive)")
    adaptive: bool = param(False, doc="true: F_N1, set by the piezo stack (a step input)")
    mass_kg: float = param(0.0, "kg", lo=0.0, doc="lumped mass on the upper beam at x: screw head, "
                           "washers (A: 0); the adaptive screw's stack adds actuator.moving_mass_kg")
    stiffness_N_m: float = param(4.0e8, "N/m", lo=0.0,
                                 doc="axial stiffness of an ordinary bolt (shank, head and engaged thread) "
                                     "acting on the beams' separation at x: F = F_N + k (g - g_ref) (A: VDI "
                                     "2230 for an M8 bolt clamping 16 mm, 4e8); 0 = a constant force. The "
                                     "adaptive screw is actuator.k_stack in series with actuator.k_screw")
    head_diameter_m: float = param(0.013, "m", lo=0.0, lo_inclusive=False,
                                   doc="bearing diameter of the head (or stack) on the upper beam: with the "
                                       "beams' thickness and width it sets the VDI 2230 pressure cone over "
                                       "which the bolt acts on the pairs (plant/bolts.py; A: M8 hex head)")


@dataclass(frozen=True)
class Point:
    """A named point on a beam where transverse motion is output (sensor or excitation)."""
    name: str
    beam: str = "main"
    x_m: float = param(0.45, "m")
    mass_kg: float = param(0.0, "kg", lo=0.0, doc="lumped mass at the point: the accelerometer, "
                           "the stinger's moving part (A: 0)")
    stiffness_N_m: float = param(0.0, "N/m", lo=0.0, doc="transverse spring from the point's w to the ground: an "
                                 "attached support, a stinger or a suspension (A: 0, none)")


@dataclass(frozen=True)
class Interface:
    """Node-to-node contact between the top of `lower` and the bottom of `upper` (SPEC 2).

    The contact parameters are per unit area (SPEC 2): a contact point carries k_n_area, k_t_area
    times its tributary area (pitch x width, half at both ends; plant/structure.py), so the pitch,
    the element length and the step refine one physical model. The per-pair keys of earlier
    versions (``k_n``, ``k_t`` [N/m]) are refused in a file or a --set with the per-area value, and
    converted with a warning in a configuration stored in a log (``LEGACY_PER_PAIR``).

    ``enabled = false``: the structure has no interface, no contact pairs and no screws (the bare
    beam, configs/bare_beam.toml); the other keys of the table are then not used."""
    enabled: bool = param(True, doc="false: no interface, no contact pairs and no screws (plant.screws "
                                    "must be empty), e.g. a bare beam; the other interface keys are unused")
    lower: str = "main"
    upper: str = "damper"
    x_start_m: float = param(0.465, "m", doc="first contact pair")
    x_end_m: float = param(0.625, "m", doc="last contact pair")
    pitch_m: float = param(0.010, "m", lo=0.0, lo_inclusive=False,
                           doc="contact point spacing: a numerical choice (docs/plant.md 6, convergence), "
                               "not a physical parameter; each point carries its tributary area")
    end_refinement: int = param(2, "-", lo=1, hi=8,
                                doc="the contact pitch near both ends of the interface is pitch_m / end_refinement "
                                    "(within end_zone_m), where the joint is closed and its slip starts "
                                    "(docs/plant.md 6.4, 6.5); 1 = pitch_m everywhere. A numerical choice like pitch_m")
    end_zone_m: float = param(0.03, "m", lo=0.0,
                              doc="length at each end of the interface sampled at pitch_m / end_refinement, rounded "
                                  "up to whole pitch_m; where the two zones meet, the whole interface is")
    layout: str = param("hand", doc="where the contact points sit (docs/plant.md 6.7): hand = pitch_m with "
                        "pitch_m / end_refinement over end_zone_m at both ends; model = the same number of points "
                        "placed by the preloaded joint's own figures (plant/layout.py): densest where slip starts "
                        "as F_N1 varies over [tracking.F_min_N, F_max_N] and over the range the adaptive screw's "
                        "contact edge covers, end_refinement times sparser over the rest of the closed contact "
                        "and end_refinement^2 times over the open interface; fronts = the same number of points, "
                        "pitch_m / end_refinement over the whole closed contact, pitch_m / end_refinement^2 where "
                        "slip starts and the edge moves, and the rest evenly over the open interface")
    mu: float = param(0.4, "-", lo=0.0, hi=2.0, doc="friction coefficient (A)")
    k_n_area: float = param(9.5e12, "N/m^3", lo=0.0, lo_inclusive=False,
                            doc="normal penalty stiffness per unit area of interface (a pair carries it times "
                                "its tributary area), calibrated to the paper's mode-3 peak at 230 Hz on the "
                                "refined joint (python -m benchmarks.calibrate_contact; docs/plant.md 6)")
    tau_s: float = param(2e-6, "s", lo=0.0, hi=1e-3,
                         doc="interface damping: Kelvin-Voigt dashpots c = k tau on the pairs (A); "
                             "damps the contact modes the 21 kHz step cannot resolve")
    dashpot_depth_m: float = param(1e-8, "m", lo=0.0, lo_inclusive=False,
                                   doc="penetration over which the tangential dashpot fades in (A): the contact "
                                       "damping grows with the pressure up to k_n_area x depth; the adaptive screw's "
                                       "points sit at 0.2..50 nm, so it shapes the controlled joint (docs/plant.md 6.2)")
    k_t_area: float = param(7.82e12, "N/m^3", lo=0.0, lo_inclusive=False,
                            doc="Jenkins tangential stiffness per unit area of interface (Mindlin ratio "
                                "2 (1 - nu) / (2 - nu) = 0.82 k_n_area)")
    static_excess: float = param(0.0, "-", lo=0.0, hi=1.0,
                                 doc="Stribeck friction: static excess s, mu(v) = mu (1 + s exp(-(v/v_s)^2)), "
                                     "mu_s = (1 + s) mu; 0 = Coulomb")
    stribeck_velocity_m_s: float = param(1e-3, "m/s", lo=0.0, lo_inclusive=False,
                                         doc="Stribeck velocity v_s (docs/plant.md, 'Stribeck friction')")
    iwan_spread: float = param(0.0, "-", lo=0.0, hi=0.95,
                               doc="micro-slip: slip limits of the Iwan element's elements spread over "
                                   "(1 -+ a) mu f_n / N; 0 = one Jenkins element")
    iwan_elements: int = param(6, "-", lo=2, hi=12, doc="elements N of the Iwan element (used if iwan_spread > 0)")


def _default_beams():
    return (Beam("main"),
            Beam("damper", x0_m=0.465, length_m=0.160, z0_m=0.008))


def _default_screws():
    return (Screw("normal", x_m=0.475, F_N=6000.0, adaptive=False),
            Screw("adaptive", x_m=0.615, F_N=100.0, adaptive=True))


def _default_points():
    return (Point("exc", "main", 0.325), Point("frf", "main", 0.45), Point("tip", "main", 0.765))


@dataclass(frozen=True)
class Plant:
    """Plant description and numerics (SPEC sections 1 and 2)."""
    beams: tuple[Beam, ...] = field(default_factory=_default_beams)
    clamps: tuple[Clamp, ...] = field(default_factory=lambda: (Clamp("main", 0.0),))
    interface: Interface = field(default_factory=Interface)
    screws: tuple[Screw, ...] = field(default_factory=_default_screws)
    points: tuple[Point, ...] = field(default_factory=_default_points)
    excitation_point: str = "exc"
    frf_point: str = "frf"
    element_length_m: float = param(0.005, "m", lo=0.0, lo_inclusive=False,
                                    doc="largest FE element (a numerical choice, docs/plant.md 6; the contact "
                                        "points are nodes, so the interface's elements are at most the pitch)")
    modal_damping: float = param(0.001, "-", lo=0.0, hi=1.0, doc="zeta of the bare beams (A)")
    quasi_static_hz: float = param(3000.0, "Hz", lo=0.0, lo_inclusive=False,
                                   doc="modes of the bolted assembly above this frequency respond quasi-statically "
                                       "(no inertia; docs/plant.md 2.6): the contact's strikes ring the modes of "
                                       "3..10.5 kHz, whose periods the 21 kHz step lengthens by 6..56 %")
    quasi_static_theta: float = param(0.9, "-", lo=0.0, hi=0.99,
                                      doc="theta of the quasi-static modes' step q1 = (1 + theta) q_static - "
                                          "theta q0 (docs/plant.md 2.6): 0 is implicit Euler (lag h/2), "
                                          "towards 1 the lag (1 - theta) h/2 vanishes and a disturbance "
                                          "decays by theta per step")
    cb_cutoff_hz: float = param(15000.0, "Hz", lo=0.0, lo_inclusive=False,
                                doc="Craig-Bampton fixed-interface modes kept up to this frequency")
    reduced: bool = param(True, doc="false: step the full FE model instead of Craig-Bampton")
    substeps: int = param(1, "-", lo=1, hi=256, doc="plant substeps per controller step")
    condense_quasi_static: bool = param(True, doc="step the quasi-static modes as their Ritz modes on the subspace "
                                                  "the contact and the inputs reach (exact; docs/plant.md 2.7): "
                                                  "at most 3 + 2 x pairs + 1 coordinates instead of every mode above "
                                                  "quasi_static_hz; false: every mode")
    period_match: bool = param(True, doc="step the Newmark modes with modal mass (omega / omega_d)^2, omega_d = "
                                         "(2/h) tan(omega h / 2), and matched damping, so that the trapezoidal "
                                         "rule's modes keep their exact frequency and damping (no period "
                                         "elongation; docs/plant.md 2.2); false: the plain trapezoid")
    period_match_stuck: bool = param(False, doc="with period_match: choose the stepped modes' modal masses and "
                                               "dampings so that the stuck, preloaded system's stepped poles below "
                                               "omega h = 1 equal those of the same step at h / 64, instead of "
                                               "matching each open-contact mode alone (docs/plant.md 2.9)")
    newton_tol_m: float = param(1e-18, "m", lo=0.0, lo_inclusive=False,
                                doc="contact Newton tolerance on the gaps (plus 64 eps max|gap|)")
    newton_max_iter: int = param(40, "-", lo=1, hi=1000)
    fallback_split: int = param(4, "-", lo=2, hi=64,
                                doc="a substep whose contact solve fails is redone as this many")
    step_scheme: str = param("trapezoidal", doc="the plant's step (docs/plant.md 2.8): trapezoidal = average "
                             "acceleration with the discrete-gradient normal impulse, the tangential dashpots' "
                             "weight at the step's start and the quasi-static theta above; generalized_alpha = "
                             "second order with the high frequencies damped to step_rho_inf per step, the "
                             "quasi-static modes and the contact law at the step's end (no theta lag), the "
                             "dashpots' weight at the extrapolated end gap; more accurate from 2 substeps on, "
                             "not at 1")
    step_rho_inf: float = param(0.8, "-", lo=0.0, hi=1.0,
                                doc="generalized_alpha: the step's spectral radius at omega h -> infinity "
                                    "(1: no numerical damping, the trapezoidal rule; 0: the most)")


@dataclass(frozen=True)
class Rt:
    """Real-time loop (SPEC section 7)."""
    rate_hz: float = param(21000.0, "Hz", lo=0.0, lo_inclusive=False, doc="controller rate, dt = 1/rate_hz")
    seed: int = param(0, "-", lo=0, doc="seed of the sensor noise")
    priority: int = param(0, "-", lo=0, hi=99, doc="paced runs: SCHED_FIFO priority of the loop thread alone "
                          "(1..99; 0: the default scheduler), docs/loop.md 'Real-time set-up'")
    cpu: int = param(-1, "-", lo=-1, doc="paced runs: the core the loop thread is pinned to; the writer and "
                     "Python move to the others (-1: not pinned)")
    sleep_margin_us: float = param(47.62, "us", lo=0.0, doc="paced runs: sleep (clock_nanosleep) until this long "
                                   "before each deadline, then spin; one period or more: spin only (the "
                                   "default: without real-time priority a sleeping thread wakes late)")
    sleep_margin_rt_us: float = param(30.0, "us", lo=0.0, doc="the same with priority > 0 (the wake-up latency "
                                      "of a SCHED_FIFO thread is short; a full spin would hit the kernel's "
                                      "real-time throttle)")
    keyframe_ticks: int = param(2100, "-", lo=0, doc="logged runs: the controller's and the plant's state is "
                                "copied into the log at every tick k with k mod keyframe_ticks = 0 (a key frame, "
                                "docs/data-format.md), where replay restarts after a gap; 0: none")
    keyframe_plant_cache: bool = param(False, doc="key frames also hold the contact solver's factor cache "
                                       "(~0.9 MB each at the default mesh): replay --plant is then bit-exact "
                                       "after a restart too, not only to round-off")


@dataclass(frozen=True)
class Tracking:
    """Control laws and force tracking (SPEC sections 3 and 4)."""
    F_min_N: float = param(40.0, "N", lo=0.0)
    F_max_N: float = param(600.0, "N", lo=0.0, lo_inclusive=False)
    law: str = param("passive", doc="passive | hysteresis | lyapunov")
    F_passive_N: float = param(40.0, "N", lo=0.0, doc="constant F_N1 of the passive law")
    passive_mode: str = param("voltage", doc="the passive law: voltage = the stack held at the voltage of "
                              "F_passive_N (the paper's 'minimal possible force', docs/tracking.md), tracking = "
                              "the force-tracking loop at the constant set-point (it fights the bolt's "
                              "response to the structure's vibration)")
    K_f: float = param(2.5e7, "N/m", lo=0.0, lo_inclusive=False, doc="hysteresis-optimal gain, F_N = K_f u0 (Eq. 3)")
    T1_s: float = param(0.020, "s", lo=0.0, lo_inclusive=False, doc="RT1 amplitude filter time constant (Eq. 4)")
    eps_m_s: float = param(0.010, "m/s", lo=0.0, lo_inclusive=False, doc="Lyapunov boundary layer")
    setpoint_filter_hz: float = param(1000.0, "Hz", lo=0.0, lo_inclusive=False,
                                      doc="2nd-order low-pass on F* before feedforward and PID "
                                          "(keeps the law's switching out of the stack resonance)")
    pid_bandwidth_hz: float = param(300.0, "Hz", lo=0.0, lo_inclusive=False,
                                    doc="target crossover of the force-tracking loop (design time)")
    pid_phase_margin_deg: float = param(60.0, "deg", lo=10.0, hi=89.0, doc="target phase margin (design time)")


@dataclass(frozen=True)
class Actuator:
    """DAC, 30 kHz analog low-pass, amplifier and piezo stack (SPEC section 3)."""
    dac_bits: int = param(16, "-", lo=8, hi=24)
    V_min: float = param(0.0, "V", doc="amplifier output range, low end")
    V_max: float = param(150.0, "V", lo=0.0, lo_inclusive=False, doc="amplifier output range, high end")
    lowpass_hz: float = param(30000.0, "Hz", lo=0.0, lo_inclusive=False, doc="analog 2nd-order Butterworth (A)")
    amp_bandwidth_hz: float = param(20000.0, "Hz", lo=0.0, lo_inclusive=False,
                                    doc="amplifier small-signal bandwidth (first order) (A)")
    current_limit_A: float = param(1.0, "A", lo=0.0, lo_inclusive=False, doc="amplifier current limit (A)")
    capacitance_F: float = param(1.5e-6, "F", lo=0.0, lo_inclusive=False, doc="piezo stack capacitance (A)")
    F0_N: float = param(40.0, "N", lo=0.0, doc="F_N1 at 0 V: F = F0 + c_v V (A)")
    c_v: float = param(3.73, "N/V", lo=0.0, lo_inclusive=False, doc="static voltage-force gain (A)")
    k_stack: float = param(2.0e7, "N/m", lo=0.0, lo_inclusive=False, doc="piezo stack stiffness (A)")
    k_screw: float = param(2.0e7, "N/m", lo=0.0, lo_inclusive=False, doc="screw stiffness in series (A)")
    moving_mass_kg: float = param(0.020, "kg", lo=0.0, lo_inclusive=False, doc="stack moving mass (A)")
    zeta_stack: float = param(0.05, "-", lo=0.0, hi=1.0, doc="damping ratio of the stack resonance (A)")
    hysteresis_width_rel: float = param(0.0, "-", lo=0.0, hi=0.3,
                                        doc="piezo hysteresis (Bouc-Wen, plant/actuator.py): width of the "
                                            "bolt force-voltage loop at mid range of a slow full-range "
                                            "triangle over the full-range force c_v (V_max - V_min); "
                                            "0 = off, typical stacks 0.1-0.15")
    creep_per_decade: float = param(0.0, "-", lo=0.0, hi=0.1,
                                    doc="creep of the screw thread's preload (plant/actuator.py): after a "
                                        "step of the stack's force F_N1 relaxes by this fraction of the "
                                        "step per decade of time, F_step (1 - c log10(1 + t / 1 ms)), "
                                        "1 ms to 10 s; c_v stays the static gain; 0 = off")
    substeps: int = param(8, "-", lo=1, hi=256, doc="actuator substeps per controller step")
    fine_substeps: int = param(8, "-", lo=1, hi=256,
                               doc="finer substeps of a substep in which the amplifier changes regime")


@dataclass(frozen=True)
class Sensors:
    """Accelerometers, bolt-force sensors and the ADC (SPEC section 3)."""
    adc_bits: int = param(16, "-", lo=8, hi=24)
    acc_range: float = param(5000.0, "m/s^2", lo=0.0, lo_inclusive=False,
                             doc="accelerometer ADC full scale +- (A, ~500 g; at 500 m/s^2 the tip's impact spikes "
                                 "under the Lyapunov law clipped one-sidedly and the integrated velocity drifted)")
    acc_noise_rms: float = param(0.01, "m/s^2", lo=0.0, doc="accelerometer noise")
    acc_bandwidth_hz: float = param(5000.0, "Hz", lo=0.0, lo_inclusive=False,
                                    doc="accelerometer + anti-alias low-pass (2nd order) (A); attenuates "
                                        "the near-Nyquist content of unresolved plant modes")
    velocity_corner_hz: float = param(2.0, "Hz", lo=0.0, lo_inclusive=False,
                                      doc="leaky integrator corner (tip velocity)")
    force_range_N: float = param(1000.0, "N", lo=0.0, lo_inclusive=False, doc="force ADC full scale (0..range)")
    strain_bandwidth_hz: float = param(1000.0, "Hz", lo=0.0, lo_inclusive=False, doc="strain-gauge bolt force")
    strain_noise_N: float = param(0.5, "N", lo=0.0, doc="strain-gauge noise rms")
    cell_bandwidth_hz: float = param(20000.0, "Hz", lo=0.0, lo_inclusive=False, doc="piezo force cell")
    cell_noise_N: float = param(0.05, "N", lo=0.0, doc="piezo force cell noise rms")


@dataclass(frozen=True)
class Observer:
    """Estimators of u_rel, v_rel at the adaptive screw (SPEC section 5)."""
    oracle_bandwidth_hz: float = param(1500.0, "Hz", lo=0.0, lo_inclusive=False,
                                       doc="oracle: the plant's u_rel, v_rel through a 2nd-order "
                                           "Butterworth (removes unresolved-mode ringing)")
    n_modes: int = param(7, "-", lo=1, hi=60, doc="modes kept in the observer's linear model (SPEC 5)")
    modal_damping: float = param(0.005, "-", lo=0.0, hi=1.0,
                                 doc="observer's modal damping ratio (A: between the bare beams' 0.1 % and "
                                     "the joint's 1.3..1.5 % at modes 3, 4)")
    mu: float = param(0.4, "-", lo=0.0, doc="observer's friction coefficient (nominal = plant.interface.mu)")
    alpha_s_m: float = param(100.0, "s/m", lo=0.0, lo_inclusive=False,
                             doc="friction regularisation f_r = mu F_N (2/pi) arctan(alpha v_rel)")
    exc_noise_N: float = param(20.0, "N", lo=0.0,
                               doc="process noise: rms per step of the unknown excitation force (Kalman)")
    fric_noise_N: float = param(100.0, "N", lo=0.0,
                                doc="process noise: rms per step of the friction model's error (Kalman); "
                                    ">= 5 exc_noise_N keeps the observer stable with the stiff stuck friction")
    meas_noise_m_s: float = param(1e-4, "m/s", lo=0.0, lo_inclusive=False,
                                  doc="measurement noise: rms of the integrated tip velocity (Kalman)")
    spring_scale: float = param(1.0, "-", lo=0.0, hi=1.0, lo_inclusive=False,
                                doc="the observer model's normal springs under the adaptive screw at this share of "
                                    "plant.interface.k_n_area: an effective stiffness of a contact that partly opens "
                                    "over the cycle (1: the stuck linearisation, SPEC 5's model; the built-in beams "
                                    "only; docs/observer.md)")


RECOVERY = ("latch", "auto")


@dataclass(frozen=True)
class Supervisor:
    """Run-time supervisor (rt/loop/supervisor.py, docs/reliability.md): checks every tick, commands
    passive F_min on a fault. Defaults: several times the largest value of a normal run (the
    three laws, oracle and observer, 5 and 20 N at 196, 223.6, 370, 430 Hz; docs/reliability.md).
    Sensor ranges are the ADC's: a reading at a full-scale code (sensors.acc_range,
    sensors.force_range_N, or 0 N) is out of range."""
    enable: bool = param(True, doc="false: monitor only (faults logged, the law's F_set kept)")
    stuck_window_s: float = param(0.01, "s", lo=0.0, lo_inclusive=False,
                                  doc="a reading unchanged this long while its partner (the other accelerometer, "
                                      "the other force sensor) changed is stuck (normal: <= 10 ticks = 0.5 ms)")
    force_disagree_N: float = param(50.0, "N", lo=0.0, lo_inclusive=False,
                                    doc="|F_strain - F_cell| above this ... (normal: > 50 N for at most 18 ticks, "
                                        "the strain gauge's 1 kHz lag under the Lyapunov law)")
    force_disagree_s: float = param(0.002, "s", lo=0.0, lo_inclusive=False,
                                    doc="... for longer than this: the force sensors disagree")
    innovation_bound_m_s: float = param(0.5, "m/s", lo=0.0, lo_inclusive=False,
                                        doc="observer: |innovation| above this is divergence (normal max 0.06 m/s)")
    state_bound: float = param(2.0, "m kg^0.5/s", lo=0.0, lo_inclusive=False,
                               doc="observer: Euclidean norm of the modal state z = [q; q'] above this is "
                                   "divergence (normal max 0.25)")
    tracking_error_N: float = param(150.0, "N", lo=0.0, lo_inclusive=False,
                                    doc="|F_set_filtered - F_meas| above this ... (normal max 99 N, > 50 N for 6 ticks)")
    tracking_error_s: float = param(0.002, "s", lo=0.0, lo_inclusive=False,
                                    doc="... for longer than this is a tracking fault")
    saturation_error_N: float = param(25.0, "N", lo=0.0,
                                      doc="amplifier at a rail with the force error pushing further by more "
                                          "than this ... (normal: > 20 N for 1 tick)")
    saturation_s: float = param(0.002, "s", lo=0.0, lo_inclusive=False,
                                doc="... for longer than this is a saturation fault")
    overrun_count: int = param(50, "-", lo=1, hi=64,
                               doc="paced: this many overrunning ticks ...")
    overrun_window_s: float = param(0.01, "s", lo=0.0, lo_inclusive=False,
                                    doc="... within this window are an overrun burst")
    recovery: str = param("latch", doc="latch: passive until the run ends; auto: active again after clean_window_s")
    clean_window_s: float = param(0.05, "s", lo=0.0, lo_inclusive=False,
                                  doc="auto recovery: this long without a failing check")


@dataclass(frozen=True)
class Impulse:
    """Simulated hammer test (SPEC section 6, Fig. 5)."""
    peak_N: float = param(50.0, "N", lo=0.0, lo_inclusive=False, doc="half-sine hammer peak force")
    duration_s: float = param(0.5e-3, "s", lo=0.0, lo_inclusive=False, doc="half-sine contact time")
    record_s: float = param(2.0, "s", lo=0.0, lo_inclusive=False, doc="record length")
    f_max_hz: float = param(1200.0, "Hz", lo=0.0, lo_inclusive=False, doc="upper end of the FRF plot and fit")


@dataclass(frozen=True)
class Shaker:
    """The shaker between the excitation generator and the plant (plant/shaker.py, docs/loop.md):
    armature on its suspension, stinger to the excitation point, force transducer at the stinger's
    tip. armature_mass_kg = 0: an ideal force source (F_exc = drive), the stage is off."""
    armature_mass_kg: float = param(0.0, "kg", lo=0.0, hi=10.0,
                                    doc="moving mass of the armature (coil, table, transducer half); "
                                        "0 = ideal force source; modal shakers 0.02-0.3")
    suspension_hz: float = param(20.0, "Hz", lo=0.0,
                                 doc="armature-on-flexure resonance f_a: k_a = m (2 pi f_a)^2 (modal shakers 10-50 Hz)")
    suspension_zeta: float = param(0.05, "-", lo=0.0, doc="its damping ratio: c_a = 2 zeta_a m (2 pi f_a)")
    stinger_N_per_m: float = param(5.0e6, "N/m", lo=0.0, lo_inclusive=False,
                                   doc="stinger axial stiffness k_s (2 mm steel rod, 130 mm: E A / L)")
    stinger_damping_Ns_per_m: float = param(20.0, "N s/m", lo=0.0, doc="stinger axial damping c_s")
    amplifier: str = param("current", doc="the power amplifier's mode: current = the coil current follows the "
                                          "drive (F_coil = drive), voltage = the coil voltage follows it (the "
                                          "coil's electrical port: back-EMF damping Bl^2 / R at the armature)")
    coil_resistance_ohm: float = param(1.5, "ohm", lo=0.0, lo_inclusive=False,
                                       doc="R: the coil's DC resistance plus the amplifier's output and cable "
                                           "resistance (100 N-class modal shakers 0.5-4; an ohmmeter at the terminals)")
    coil_inductance_H: float = param(3.0e-4, "H", lo=0.0,
                                     doc="L: the coil's inductance (100 N-class modal shakers 0.1-1 mH)")
    force_constant_N_per_A: float = param(10.0, "N/A", lo=0.0, lo_inclusive=False,
                                          doc="Bl: coil force per ampere = back-EMF per m/s (100 N-class modal "
                                              "shakers 5-30 N/A: rated force / rated current)")

    @property
    def on(self) -> bool:
        """False: ideal force source (no shaker stage in the loop)."""
        return self.armature_mass_kg > 0.0

    @property
    def back_emf_damping_Ns_per_m(self) -> float:
        """c_e = Bl^2 / R [N s/m]: the damping the coil's back-EMF adds at the armature in voltage mode
        (below the electrical corner R / (2 pi L)); 0 in current mode."""
        return self.force_constant_N_per_A ** 2 / self.coil_resistance_ohm if self.amplifier == "voltage" else 0.0


@dataclass(frozen=True)
class Uncertainty:
    """How uncertain the user says the nominal values of the calibrated parameters are: each sets the
    parameter's plausible range (rt.discrepancy.diagnose.plausible: inside it the diagnosis' fits are free, outside
    they are penalised and the parameter is reported as evidence of a missing effect or a wrong model
    form). A factor of 0 means the range the literature gives for what the parameter is (the table in
    rt/discrepancy/diagnose/plausible.py); a factor f >= 1 the nominal / f .. nominal x f instead."""
    E_rel: float = param(0.05, "-", lo=0.0, lo_inclusive=False,
                         doc="the beams' Young's modulus lies within nominal x (1 -+ E_rel): a named metal's E is "
                             "known to a few % (structural steels 195-215 GPa, wrought aluminium alloys 68-72 GPa)")
    k_t_factor: float = param(0.0, "-", lo=0.0,
                              doc="tangential contact stiffness per area plant.interface.k_t_area within nominal / f "
                                  ".. x f; 0: the literature's 1e12..1e14 N/m^3 of ground steel, scaled to the "
                                  "interface's materials by their contact modulus")
    mu_factor: float = param(0.0, "-", lo=0.0,
                             doc="friction coefficient plant.interface.mu within nominal / f .. x f; 0: the "
                                 "literature's 0.1..1.5 of dry metal on metal")
    modal_damping_factor: float = param(0.0, "-", lo=0.0,
                                        doc="plant.modal_damping within nominal / f .. x f; 0: the literature's "
                                            "5e-4..5e-2 (0.05..5 %) of bolted metal structures")
    clamp_heights: float = param(3.0, "-", lo=0.0,
                                 doc="a clamp's rotational compliance lies within 0 .. clamp_heights x h / (E I) of "
                                     "its beam: the fixture is as compliant as at most this many beam heights h of "
                                     "extra beam (A)")


@dataclass(frozen=True)
class Diagnosis:
    """Settings of the discrepancy diagnosis (``frictionrt diagnose``, docs/discrepancy.md)."""
    uncertainty: Uncertainty = field(default_factory=Uncertainty)
    model_form: str = param("auto", doc="the model-form candidates of FRF-file input (rt.discrepancy.effects."
                            "MODEL_FORMS: the clamp's translation, the joint's compliance, a mass and a spring at "
                            "attach_point): auto = tried when the calibration alone needs a parameter at or beyond "
                            "its plausible range; always; never")
    attach_point: str = param("", doc="the plant point (plant.points) where the attached_mass and attached_spring "
                              "candidates sit; empty: plant.excitation_point (the stinger's or hammer's point)")


@dataclass(frozen=True)
class Config:
    """The whole configuration tree."""
    rt: Rt = field(default_factory=Rt)
    plant: Plant = field(default_factory=Plant)
    tracking: Tracking = field(default_factory=Tracking)
    actuator: Actuator = field(default_factory=Actuator)
    sensors: Sensors = field(default_factory=Sensors)
    observer: Observer = field(default_factory=Observer)
    supervisor: Supervisor = field(default_factory=Supervisor)
    impulse: Impulse = field(default_factory=Impulse)
    shaker: Shaker = field(default_factory=Shaker)
    diagnosis: Diagnosis = field(default_factory=Diagnosis)

    @property
    def dt_s(self) -> float:
        """Controller step [s]."""
        return 1.0 / self.rt.rate_hz


# --- loading and merging --------------------------------------------------------------------

@functools.cache
def _field_types(cls) -> dict[str, Any]:
    """The resolved field types of dataclass ``cls``, once per class: ``get_type_hints`` evaluates
    the string annotations (``from __future__ import annotations``) on every call, which was ~half
    of each ``with_sets`` (a diagnosis builds thousands of configurations). Read only: ``_build``
    iterates the dict and never changes it."""
    return get_type_hints(cls)


def _shown(text: str) -> str:
    """A key or --set argument as a message shows it: as given, or quoted with escapes if it holds
    characters that would break the one-line message (newlines, control characters)."""
    return text if text.isprintable() else repr(text)


def _shown_set(assignment: str) -> str:
    """A --set KEY=VALUE as a message shows it (``_shown`` on key and value)."""
    key, eq, value = assignment.partition("=")
    value = _shown(value)
    return f"{_shown(key)}{eq}{value if len(value) <= 60 else value[:50] + '...'}"


def _short(value) -> str:
    """repr of a user's value, cut to 60 characters (a message stays one short line)."""
    r = repr(value)
    return r if len(r) <= 60 else r[:50] + f"... ({len(r)} chars)"


def _build(cls, data: dict, path: str):
    """Build dataclass `cls` from a plain dict, refusing unknown keys and wrong types."""
    if not isinstance(data, dict):
        raise ConfigError(f"{path or 'configuration'}: expected a table, got {_short(data)}")
    types = _field_types(cls)
    unknown = set(data) - set(types)
    if unknown:
        key = sorted(unknown)[0]
        raise ConfigError(f"{_join(path, _shown(key))}: unknown key; allowed keys here: {', '.join(types)}")
    kwargs = {}
    for name, typ in types.items():
        if name in data:
            kwargs[name] = _convert(typ, data[name], _join(path, name))
    missing = [f.name for f in dataclasses.fields(cls)
               if f.name not in kwargs and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING]
    if missing:  # e.g. a beam without a name
        raise ConfigError(f"{path}: missing key {missing[0]!r} (required)")
    return cls(**kwargs)


def _convert(typ, value, path: str):
    origin = get_origin(typ)
    if dataclasses.is_dataclass(typ):
        return _build(typ, value, path)
    if origin is tuple:
        (item,) = [a for a in get_args(typ) if a is not Ellipsis]
        if not isinstance(value, (list, tuple)):
            raise ConfigError(f"{path}: expected an array of tables, got {_short(value)}")
        return tuple(_convert(item, v, f"{path}[{_element(v, i)}]") for i, v in enumerate(value))
    if typ is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{path} = {_short(value)}: expected true or false")
        return value
    if typ is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{path} = {_short(value)}: expected an integer")
        if not INT64[0] <= value <= INT64[1]:
            raise ConfigError(f"{path} = {_short(value)}: outside the 64-bit integer range")
        return value
    if typ is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{path} = {_short(value)}: expected a number")
        try:
            return float(value)
        except OverflowError:  # an integer beyond float64 (~1.8e308)
            raise ConfigError(f"{path} = {_short(value)}: too large for a float64 number") from None
    if typ is str:
        if not isinstance(value, str):
            raise ConfigError(f"{path} = {_short(value)}: expected a string")
        return value
    raise ConfigError(f"{path}: unsupported type {typ}")  # pragma: no cover - schema error


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


def _element(v, i: int) -> str:
    """How a message names list element i (a dict or a built item): by its name if it has a
    printable one, else by its index."""
    name = v.get("name") if isinstance(v, dict) else getattr(v, "name", None)
    return name if isinstance(name, str) and name.isprintable() and name else str(i)


def to_dict(obj) -> dict:
    """Plain nested dict (tuples of tables become lists) of a configuration object."""
    out = {}
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if dataclasses.is_dataclass(v):
            out[f.name] = to_dict(v)
        elif isinstance(v, tuple):
            out[f.name] = [to_dict(x) for x in v]
        else:
            out[f.name] = v
    return out


def _merge(base: dict, over: dict) -> dict:
    """Deep-merge `over` into `base`; arrays of tables are replaced whole."""
    out = dict(base)
    for k, v in over.items():
        out[k] = _merge(base[k], v) if isinstance(v, dict) and isinstance(base.get(k), dict) else v
    return out


def _parse_value(text: str):
    """A --set value: TOML literal if it parses as one value (number, bool, quoted string, array),
    else a bare string."""
    try:
        doc = tomllib.loads(f"v = {text}")
    except tomllib.TOMLDecodeError:
        return text
    return doc["v"] if list(doc) == ["v"] else text


# --- the per-pair contact keys of earlier versions ------------------------------------------

LEGACY_PER_PAIR = {"k_n": "k_n_area", "k_t": "k_t_area"}
"""Per-pair contact stiffness keys [N/m] of plant.interface before the contact became per unit
area, and their per-area successors [N/m^3]."""


def _pair_area(data: dict) -> tuple[float, float, float]:
    """(area [m^2], pitch [m], width [m]) of one interior contact pair in a configuration dict:
    pitch x the narrower interface beam's width (the conversion of a per-pair stiffness)."""
    itf = data["plant"]["interface"]
    widths = [b.get("width_m", Beam.width_m) for b in data["plant"]["beams"]
              if isinstance(b, dict) and b.get("name") in (itf.get("lower"), itf.get("upper"))]
    width = float(min(widths)) if widths else Beam.width_m
    pitch = float(itf.get("pitch_m", Interface.pitch_m))
    return pitch * width, pitch, width


def _per_area_text(data: dict, key: str, value) -> str:
    """One line: the per-pair ``key`` = ``value`` is gone, and the per-area value that replaces it."""
    area, pitch, width = _pair_area(data)
    new = LEGACY_PER_PAIR[key]
    try:
        per_area = f"{float(value) / area:.6g}"
    except (TypeError, ValueError):
        per_area = "(that value / the pair's area)"
    return (f"plant.interface.{key} = {_short(value)} N/m per pair is no longer a key: the contact is per unit "
            f"area (SPEC 2); use plant.interface.{new} = {per_area} N/m^3 (= {key} / ({pitch:g} m pitch x "
            f"{width:g} m width))")


def _legacy_contact(data: dict, stored: bool, source: str) -> None:
    """Handle per-pair contact keys in ``data`` (a merged configuration dict) in place: a stored
    configuration (a log's) is converted to the per-area keys with a warning; any other input is
    refused with the per-area value (ConfigError)."""
    itf = data.get("plant", {}).get("interface")
    if not isinstance(itf, dict):
        return
    for key, new in LEGACY_PER_PAIR.items():
        if key not in itf:
            continue
        text = _per_area_text(data, key, itf[key])
        if not stored:
            raise ConfigError(f"{source}: {text}")
        area = _pair_area(data)[0]
        itf[new] = float(itf.pop(key)) / area
        warnings.warn(f"{source}: {text}; converted (the earlier plant gave the end pairs a whole pair's "
                      "stiffness, the converted one half)", stacklevel=2)


def _end_refinement_of(pitch: float, end_pitch) -> int:
    """The end_refinement that replaces the earlier ``end_pitch_m`` at ``pitch`` [m] (0 or none: 1)."""
    return round(pitch / end_pitch) if isinstance(end_pitch, (int, float)) and end_pitch > 0 else 1


def _end_pitch_text(end_pitch, r: int) -> str:
    """One line: the earlier ``end_pitch_m`` is gone, and the end_refinement that replaces it."""
    return (f"plant.interface.end_pitch_m = {_short(end_pitch)} m is no longer a key: use plant.interface."
            f"end_refinement = {r} (pitch_m / end_pitch_m; 1 = pitch_m everywhere)")


def _legacy_layout(data: dict, over: dict, stored: bool, source: str) -> None:
    """Handle the contact layout of earlier versions in ``data`` (merged) in place, from ``over`` (the
    text's own keys): a stored configuration without ``end_refinement`` ran at a uniform pitch, so it
    gets end_refinement = 1, or pitch_m / end_pitch_m if it has the earlier ``end_pitch_m`` (with a
    warning); any other input that gives ``end_pitch_m`` is refused with the key that replaces it."""
    itf_over = over.get("plant", {}).get("interface")
    itf = data.get("plant", {}).get("interface")
    if not isinstance(itf, dict):
        return
    itf_over = itf_over if isinstance(itf_over, dict) else {}
    if not stored and "end_pitch_m" not in itf_over:
        return
    end_pitch = itf.pop("end_pitch_m", 0.0)
    if "end_refinement" in itf_over:
        return
    r = _end_refinement_of(float(itf.get("pitch_m", Interface.pitch_m)), end_pitch)
    text = _end_pitch_text(end_pitch, r)
    if not stored:
        raise ConfigError(f"{source}: {text}")
    if "end_pitch_m" in itf_over and r > 1:   # 0 is the uniform layout: nothing to say
        warnings.warn(f"{source}: {text}; converted", stacklevel=3)
    itf["end_refinement"] = r


def _apply_set(data: dict, assignment: str) -> None:
    """Apply one ``key=value``; list elements are addressed by their ``name``."""
    if "=" not in assignment:
        raise ConfigError(f"--set {assignment!r}: expected KEY=VALUE, e.g. plant.interface.mu=0.3")
    key, text = assignment.split("=", 1)
    parts = key.strip().split(".")
    if parts[:2] == ["plant", "interface"] and len(parts) == 3 and parts[2] in LEGACY_PER_PAIR:
        raise ConfigError(f"--set {_shown(key)}: {_per_area_text(data, parts[2], _parse_value(text.strip()))}")
    if parts == ["plant", "interface", "end_pitch_m"]:
        value = _parse_value(text.strip())
        r = _end_refinement_of(float(data["plant"]["interface"].get("pitch_m", Interface.pitch_m)), value)
        raise ConfigError(f"--set {_shown(key)}: {_end_pitch_text(value, r)}")
    node, path = data, ""
    shown = _shown(key)
    for i, part in enumerate(parts):
        last = i == len(parts) - 1
        if isinstance(node, list):
            named = [x for x in node if isinstance(x, dict) and x.get("name") == part]
            if not named:
                names = [x.get("name") for x in node if isinstance(x, dict)]
                raise ConfigError(f"--set {shown}: no element named {part!r} in {path}; names: {names}")
            if last:
                raise ConfigError(f"--set {shown}: give a field of {part!r}, e.g. {shown}.x_m=0.5")
            node = named[0]
            path = _join(path, part)
            continue
        if not isinstance(node, dict):
            raise ConfigError(f"--set {shown}: {path} is a single value ({_short(node)}), it has no field {part!r}")
        path = _join(path, part)
        if part not in node:
            raise ConfigError(f"--set {shown}: unknown key {path!r}; allowed here: {', '.join(node)}")
        if last:
            node[part] = _parse_value(text.strip())
        else:
            node = node[part]


def load(config_file: str | Path | None = None, sets: list[str] | tuple[str, ...] = ()) -> Config:
    """Resolve defaults <- TOML file <- ``--set`` overrides, then validate.

    Raises ConfigError with a message naming the file, key or value at fault.
    """
    if config_file is None:
        return _resolve(to_dict(Config()), sets)
    p = Path(config_file)
    try:
        text = p.read_bytes().decode()
    except FileNotFoundError:
        raise ConfigError(f"{p}: configuration file not found") from None
    except OSError as exc:  # a folder, no permission, ...
        raise ConfigError(f"{p}: cannot read the configuration file ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{p}: not valid TOML (not UTF-8 text: {exc.reason} at byte {exc.start})") from None
    return loads(text, sets, source=str(p))


def loads(text: str, sets: list[str] | tuple[str, ...] = (), source: str = "configuration",
          stored: bool = False) -> Config:
    """``load`` of TOML ``text``; ``source`` names the text in messages. ``stored``: the text is
    a configuration stored in a log, whose per-pair contact keys of earlier versions are converted
    with a warning instead of refused (``_legacy_contact``)."""
    try:
        over = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML ({exc})") from None
    data = _merge(to_dict(Config()), over)
    _legacy_contact(data, stored, source)
    _legacy_layout(data, over, stored, source)
    return _resolve(data, sets, source)


def with_sets(cfg: Config, sets: list[str] | tuple[str, ...]) -> Config:
    """``cfg`` with ``--set`` style overrides applied (e.g. one candidate of a gain sweep),
    validated; raises ConfigError as ``load`` does."""
    return _resolve(to_dict(cfg), sets)


def refined_sets(cfg: Config, factor: int) -> list[str]:
    """--set assignments of ``cfg``'s discretisation refined by ``factor``: the contact pitch and
    the element length divided by it, the plant substeps multiplied by its square (the step's
    error falls at first order, the pitch's faster; docs/plant.md 6). The physical model (contact
    per unit area) is unchanged."""
    p = cfg.plant
    return [f"plant.interface.pitch_m={p.interface.pitch_m / factor!r}",
            f"plant.element_length_m={p.element_length_m / factor!r}",
            f"plant.substeps={p.substeps * factor * factor}"]


def check_key(cfg: Config, key: str) -> None:
    """Raise ConfigError (naming the allowed keys) if ``key`` is not a field that --set reaches."""
    _apply_set(to_dict(cfg), f"{key}=0")


def key_range(cfg: Config, key: str) -> tuple[float | None, float | None, bool]:
    """(lo, hi, lo_inclusive) that ``validate`` allows for the numeric --set ``key`` of ``cfg`` (list
    elements by name, e.g. plant.beams.main.E): its ``param`` declaration; None where unbounded.
    ConfigError naming the allowed keys for a key --set does not reach."""
    check_key(cfg, key)
    *path, name = key.split(".")
    obj = cfg
    for part in path:
        obj = next(x for x in obj if x.name == part) if isinstance(obj, tuple) else getattr(obj, part)
    meta = next(f.metadata for f in dataclasses.fields(obj) if f.name == name)
    return meta.get("lo"), meta.get("hi"), meta.get("lo_inclusive", True)


def _resolve(data: dict, sets, source: str | None = None) -> Config:
    """``data`` with the ``sets`` applied, built and validated; a refusal names the input it is
    due to (``_blame``)."""
    base = copy.deepcopy(data)
    for s in sets:
        _apply_set(data, s)
    try:
        return _checked(data)
    except ConfigError as exc:
        raise ConfigError(f"{_blame(base, sets, source)}: {exc}") from None


def _checked(data: dict) -> Config:
    cfg = _build(Config, data, "")
    validate(cfg)
    return cfg


def _blame(base: dict, sets, source: str | None) -> str:
    """The input a refused configuration is due to: ``source`` (the file) if ``base`` is refused
    without the --set overrides, else the first --set refused on its own, else all of them."""
    try:
        _checked(copy.deepcopy(base))
    except ConfigError:
        return source or "configuration"
    for s in sets:
        data = copy.deepcopy(base)
        try:
            _apply_set(data, s)   # may address what an earlier --set made: skip it then
            _checked(data)
        except ConfigError:
            return f"--set {_shown_set(s)}"
    return "--set " + " --set ".join(_shown_set(s) for s in sets) + " together"


# --- validation -----------------------------------------------------------------------------

def _range_text(meta) -> str:
    lo, hi = meta["lo"], meta["hi"]
    unit = f" {meta['unit']}" if meta["unit"] not in ("", "-") else ""
    left = "" if lo is None else (f"{lo:g} <= " if meta["lo_inclusive"] else f"{lo:g} < ")
    right = "" if hi is None else f" <= {hi:g}"
    return f"{left}value{right}{unit}" if (left or right) else f"a finite number{unit}"


def _check_fields(obj, path: str) -> None:
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        key = _join(path, f.name)
        if dataclasses.is_dataclass(v):
            _check_fields(v, key)
        elif isinstance(v, tuple):
            for i, item in enumerate(v):
                _check_fields(item, f"{key}[{_element(item, i)}]")
        elif isinstance(v, (int, float)) and not isinstance(v, bool):
            meta = f.metadata
            lo, hi = meta.get("lo"), meta.get("hi")
            bad = not math.isfinite(v)
            if lo is not None:
                bad |= v < lo or (v == lo and not meta.get("lo_inclusive", True))
            if hi is not None:
                bad |= v > hi
            if bad:
                raise ConfigError(f"{key} = {v!r} is not allowed: must be {_range_text(meta)}")


def _names(items, what: str, path: str) -> dict:
    out = {}
    for it in items:
        if it.name in out:
            raise ConfigError(f"{path}: two {what} named {it.name!r}; names must be unique")
        out[it.name] = it
    return out


def validate(cfg: Config) -> None:
    """Refuse values outside their range and inconsistent structure descriptions."""
    _check_fields(cfg, "")
    p = cfg.plant
    t = cfg.tracking
    if t.law not in LAWS:
        raise ConfigError(f"tracking.law = {t.law!r}: must be one of {', '.join(LAWS)}")
    if cfg.shaker.amplifier not in AMPLIFIERS:
        raise ConfigError(f"shaker.amplifier = {cfg.shaker.amplifier!r}: must be one of {', '.join(AMPLIFIERS)}")
    if cfg.diagnosis.model_form not in MODEL_FORM_MODES:
        raise ConfigError(f"diagnosis.model_form = {cfg.diagnosis.model_form!r}: must be one of "
                          f"{', '.join(MODEL_FORM_MODES)}")
    if p.step_scheme not in STEP_SCHEMES:
        raise ConfigError(f"plant.step_scheme = {p.step_scheme!r}: must be one of {', '.join(STEP_SCHEMES)}")
    if p.interface.layout not in LAYOUTS:
        raise ConfigError(f"plant.interface.layout = {p.interface.layout!r}: must be one of {', '.join(LAYOUTS)}")
    if t.passive_mode not in PASSIVE_MODES:
        raise ConfigError(f"tracking.passive_mode = {t.passive_mode!r}: must be one of {', '.join(PASSIVE_MODES)}")
    if cfg.supervisor.recovery not in RECOVERY:
        raise ConfigError(f"supervisor.recovery = {cfg.supervisor.recovery!r}: must be one of {', '.join(RECOVERY)}")
    a = cfg.actuator
    if a.V_min >= a.V_max:
        raise ConfigError(f"actuator.V_min = {a.V_min:g} V must be below actuator.V_max = {a.V_max:g} V")
    if t.F_min_N > t.F_max_N:
        raise ConfigError(f"tracking.F_min_N = {t.F_min_N:g} N > tracking.F_max_N = {t.F_max_N:g} N: "
                          "F_min must not exceed F_max")
    beams = _names(p.beams, "beams", "plant.beams")
    points = _names(p.points, "points", "plant.points")
    screws = _names(p.screws, "screws", "plant.screws")

    def on_beam(where, beam_name, x):
        if beam_name not in beams:
            raise ConfigError(f"{where}.beam = {beam_name!r}: unknown beam; beams: {', '.join(beams)}")
        key = f"{where}.x_m"
        b = beams[beam_name]
        if not (b.x0_m - 1e-12 <= x <= b.x0_m + b.length_m + 1e-12):
            raise ConfigError(f"{key} = {x:g} m lies outside beam {beam_name!r} "
                              f"[{b.x0_m:g}, {b.x0_m + b.length_m:g}] m")

    for j, c in enumerate(p.clamps):
        on_beam(f"plant.clamps[{j}]", c.beam, c.x_m)
    for j, pt in enumerate(p.points):
        on_beam(f"plant.points[{_element(pt, j)}]", pt.beam, pt.x_m)
    for key in ("excitation_point", "frf_point"):
        if getattr(p, key) not in points:
            raise ConfigError(f"plant.{key} = {getattr(p, key)!r}: no such point; points: {', '.join(points)}")
    if cfg.diagnosis.attach_point and cfg.diagnosis.attach_point not in points:
        raise ConfigError(f"diagnosis.attach_point = {cfg.diagnosis.attach_point!r}: no such point; give one of "
                          f"{', '.join(points)} (or leave it empty: the excitation point)")

    if p.interface.enabled:
        _check_interface(p, beams, screws)
    elif p.screws:
        raise ConfigError(f"plant.screws: {len(p.screws)} screw(s) ({', '.join(screws)}) but "
                          "plant.interface.enabled = false: a screw clamps the interface; remove the screws "
                          "(plant.screws = []) or enable the interface")
    _check_adaptive(p, t)
    _check_uncertainty(cfg.diagnosis.uncertainty)


E_REL_MAX = 0.9   # diagnosis.uncertainty.E_rel above this leaves E's plausible range without a positive lower end


def _check_uncertainty(u: Uncertainty) -> None:
    """Refuse an E_rel above E_REL_MAX and a factor between 0 and 1, naming the value and the fix."""
    key = "diagnosis.uncertainty"
    if u.E_rel > E_REL_MAX:
        raise ConfigError(f"{key}.E_rel = {u.E_rel!r}: it is a fraction of the nominal E, at most {E_REL_MAX:g} "
                          f"(E within nominal x (1 -+ E_rel)); for E known to +-5 % give 0.05")
    for name in ("k_t_factor", "mu_factor", "modal_damping_factor"):
        f = getattr(u, name)
        if 0.0 < f < 1.0:
            raise ConfigError(f"{key}.{name} = {f!r}: a factor f gives the range nominal / f .. nominal x f, so it is "
                              f"at least 1 (e.g. 2 for a value known within a factor 2), or 0 for the literature's "
                              f"range; did you mean {1.0 / f:g}?")


def adaptive_screw(cfg: Config) -> Screw | None:
    """The adaptive screw (the piezo stack's F_N1) of the structure, or None if it has none."""
    return next((s for s in cfg.plant.screws if s.adaptive), None)


def require_adaptive_screw(cfg: Config, what: str) -> Screw:
    """The adaptive screw; ConfigError naming ``what`` (a command or function) if the structure has none."""
    screw = adaptive_screw(cfg)
    if screw is None:
        raise ConfigError(f"{what} needs an adaptive screw (a plant.screws entry with adaptive = true) and this "
                          "structure has none; without one: config, modes, impulse, rig --frf-files, diagnose "
                          "on FRF files, bench plant, validate, inspect, recover")
    return screw


def _check_adaptive(p: Plant, t: Tracking) -> None:
    """Zero or one adaptive screw; its initial F_N1 within [F_min, F_max]."""
    adaptive = [s for s in p.screws if s.adaptive]
    if len(adaptive) > 1:
        raise ConfigError(f"plant.screws: at most one screw may be adaptive (F_N1, the piezo stack), found "
                          f"{len(adaptive)} ({', '.join(s.name for s in adaptive)}); set adaptive = false on "
                          "all but one (an ordinary bolt keeps its F_N as preload)")
    for s in adaptive:
        if not (t.F_min_N <= s.F_N <= t.F_max_N):
            raise ConfigError(f"plant.screws[{_shown(s.name)}].F_N = {s.F_N:g} N lies outside "
                              f"[tracking.F_min_N, tracking.F_max_N] = [{t.F_min_N:g}, {t.F_max_N:g}] N")


def _check_interface(p: Plant, beams: dict, screws: dict) -> None:
    """The interface joins two touching beams over whole pitches; the screws lie on it."""
    i = p.interface
    for role in ("lower", "upper"):
        if getattr(i, role) not in beams:
            raise ConfigError(f"plant.interface.{role} = {getattr(i, role)!r}: no such beam; "
                              f"beams: {', '.join(beams)}")
    if i.lower == i.upper:
        raise ConfigError(f"plant.interface.upper = {i.upper!r}: lower and upper must be different beams")
    lo_b, up_b = beams[i.lower], beams[i.upper]
    if i.x_end_m <= i.x_start_m:
        raise ConfigError(f"plant.interface.x_end_m = {i.x_end_m:g} m must exceed x_start_m = {i.x_start_m:g} m "
                          "(the contact is per unit area: an interface of no length carries nothing)")
    for key in ("x_start_m", "x_end_m"):
        for b in (lo_b, up_b):
            x = getattr(i, key)
            if not (b.x0_m - 1e-12 <= x <= b.x0_m + b.length_m + 1e-12):
                raise ConfigError(f"plant.interface.{key} = {x:g} m lies outside beam {b.name!r} "
                                  f"[{b.x0_m:g}, {b.x0_m + b.length_m:g}] m")
    n = (i.x_end_m - i.x_start_m) / i.pitch_m
    if not math.isfinite(n) or abs(n - round(n)) > 1e-6:
        raise ConfigError(f"plant.interface.pitch_m = {i.pitch_m:g} m does not divide the interface "
                          f"length {i.x_end_m - i.x_start_m:g} m into whole pitches")
    gap = (up_b.z0_m - up_b.height_m / 2) - (lo_b.z0_m + lo_b.height_m / 2)
    if abs(gap) > 1e-9:
        raise ConfigError(f"plant.beams[{_shown(up_b.name)}].z0_m = {up_b.z0_m:g} m: the bottom of {up_b.name!r} "
                          f"must touch the top of {lo_b.name!r} (set z0_m = "
                          f"{lo_b.z0_m + (lo_b.height_m + up_b.height_m) / 2:g} m)")
    for s in screws.values():
        if not (i.x_start_m - 1e-12 <= s.x_m <= i.x_end_m + 1e-12):
            raise ConfigError(f"plant.screws[{_shown(s.name)}].x_m = {s.x_m:g} m lies outside the damper interface "
                              f"[{i.x_start_m:g}, {i.x_end_m:g}] m")


# --- printing -------------------------------------------------------------------------------

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    return repr(v)


def _comment(meta) -> str:
    parts = []
    if meta.get("unit") and meta["unit"] != "-":
        parts.append(f"[{meta['unit']}]")
    if meta.get("doc"):
        parts.append(meta["doc"])
    return f"  # {' '.join(parts)}" if parts else ""


def _emit(obj, path: str, lines: list[str], header: str | None) -> None:
    # an empty array of tables (no screws) is written as `key = []`: omitted, loading would restore the defaults
    scalars = [f for f in dataclasses.fields(obj)
               if not dataclasses.is_dataclass(getattr(obj, f.name))
               and not (isinstance(getattr(obj, f.name), tuple) and getattr(obj, f.name))]
    if header:
        lines.append("")
        lines.append(header)
    for f in scalars:
        v = getattr(obj, f.name)
        text = "[]" if v == () else _toml_value(v)
        lines.append(f"{f.name} = {text}{_comment(f.metadata)}")
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        key = _join(path, f.name)
        if dataclasses.is_dataclass(v):
            _emit(v, key, lines, f"[{key}]")
        elif isinstance(v, tuple):
            for item in v:
                _emit(item, key, lines, f"[[{key}]]")


def dumps(cfg: Config) -> str:
    """The resolved configuration as TOML with units in comments (loadable by ``load``)."""
    lines: list[str] = ["# frictionrt resolved configuration (SI units)"]
    _emit(cfg, "", lines, None)
    return "\n".join(lines) + "\n"
