"""The loop's design time: everything a run needs, built once from the configuration (``Loop``),
the log's columns, and the loop's state between two ticks (``LoopState``) at rest.

The run-time side is rt/loop/tick.py (the compiled tick), rt/loop/driver.py (``run``: the thread
that drives it) and rt/loop/results.py (the figures of a finished run).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from frictionrt.observer.amplitude import AmplitudeParams, design_amplitude, no_amplitude
from frictionrt.observer.kalman import ObserverParams, design_observer
from frictionrt.observer.oracle import ORACLE_OUTPUTS, build_oracle
from frictionrt.observer.step import OBSERVER_OUTPUTS
from frictionrt.plant.actuator import ACTUATOR_OUTPUTS, ActuatorParams, build_actuator
from frictionrt.plant.actuator import initial_state as actuator_initial_state
from frictionrt.plant.actuator import output_index as actuator_output_index
from frictionrt.plant.model import PlantModel, build_plant
from frictionrt.plant.sensors import SENSOR_OUTPUTS, SensorParams, build_sensors
from frictionrt.plant.sensors import initial_state as sensors_initial_state
from frictionrt.plant.sensors import output_index as sensor_output_index
from frictionrt.plant.shaker import ShakerParams, build_shaker, check_shaker
from frictionrt.rt.common.config import (ALL_ESTIMATORS, DEFAULT_ESTIMATOR, ESTIMATORS, OBSERVERS, Config,  # noqa: F401  (ESTIMATORS: the face)
                                         estimator_of, require_adaptive_screw)
from frictionrt.rt.common.noise import new_rng
from frictionrt.rt.loop.structure import Structure, build_structure_plant
from frictionrt.rt.loop.supervisor import SUPERVISOR_OUTPUTS, SupervisorParams, build_supervisor
from frictionrt.rt.loop.supervisor import initial_state as supervisor_initial_state
from frictionrt.tracking.force_tracking import FORCE_TRACKING_OUTPUTS, SENSOR_OF_LAW, ForceTrackingDesign, design_force_tracking
from frictionrt.tracking.force_tracking import initial_state as tracking_initial_state
from frictionrt.tracking.laws import LAWS_OUTPUTS, LAWS_SLOTS, build_laws
from frictionrt.tracking.lowpass import BiquadParams, rest_state
from frictionrt.tracking.prefilter import PREFILTER_OUTPUTS, build_prefilter

COMPONENTS = ("sensors", "estimator", "law", "supervisor", "tracking", "actuator", "plant", "log")


@dataclass(frozen=True)
class Loop:
    """Everything a run needs, built once at design time from the configuration."""
    cfg: Config
    law: str
    plant: PlantModel
    actuator: ActuatorParams
    sensors: SensorParams
    oracle: BiquadParams
    observer: ObserverParams  # the designed observer, or empty arrays when the oracle runs
    prefilter: BiquadParams
    law_params: object
    design: ForceTrackingDesign
    force_sensor: str
    signals: tuple[tuple[str, str, str], ...]   # (name, unit, owner) per log column
    estimator: str = DEFAULT_ESTIMATOR          # an Estimator (its string value)
    supervisor: SupervisorParams | None = None  # built by build_loop
    shaker: ShakerParams | None = None          # built by build_loop (P = 0: ideal force source)
    plant_rest: np.ndarray | None = None        # built by build_loop: the plant's state at rest at F0
    #                                             (plant.initial_state, a static solve: 6.5 ms, once per loop, not per run)
    amplitude: AmplitudeParams | None = None    # the amplitude-following blocks (estimator "amplitude"), else of size 0
    structure: Structure | None = None          # an imported structure (rt.loop.structure) as the plant; None: the beams

    @property
    def observes(self) -> bool:
        """True when an observer kind runs (state z in LoopState.xe), False for the oracle."""
        return self.estimator in OBSERVERS

    def column(self, name: str) -> int:
        return next(i for i, (n, _, _) in enumerate(self.signals) if n == name)


def loop_signals(plant: PlantModel) -> tuple[tuple[str, str, str], ...]:
    """Log columns in order: (name, unit, owning package)."""
    sig = [("F_exc", "N", "rt")]
    sig += [(n, u, "sensors") for n, u in SENSOR_OUTPUTS]
    sig += [(n, u, "observer") for n, u in OBSERVER_OUTPUTS]  # the oracle fills the first two
    sig += [(n, u, "tracking") for n, u in LAWS_OUTPUTS]
    sig += [(n, u, "tracking") for n, u in PREFILTER_OUTPUTS]
    sig += [(n, u, "tracking") for n, u in FORCE_TRACKING_OUTPUTS]
    sig += [(n, u, "rt") for n, u in SUPERVISOR_OUTPUTS]
    sig += [(n, u, "actuator") for n, u in ACTUATOR_OUTPUTS]
    sig += [(n, u, "plant") for n, u in plant.output_labels()]
    sig += [("tick_ns", "ns", "rt"), ("late_ns", "ns", "rt")]
    return tuple(sig)


class Designs:
    """The two expensive design steps, made once for the loops of one study (the laws of a
    reproduction, the candidates of a tuning grid) and shared: the plant (``build_plant``, 0.9 s)
    per distinct rt, plant and actuator sections (what it reads), the force-tracking design
    (``design_force_tracking``, 0.8 s) per sensor and distinct rt, actuator and sensors sections
    and tracking.pid_bandwidth_hz, pid_phase_margin_deg (what it reads). The objects are those
    built alone, the same bits (design runs in one process)."""

    def __init__(self):
        self._made: dict = {}

    def _get(self, key, make):
        if key not in self._made:
            self._made[key] = make()
        return self._made[key]

    def plant(self, cfg: Config, structure: Structure | None = None) -> PlantModel:
        """``build_plant(cfg)``, built once per distinct (cfg.rt, cfg.plant, cfg.actuator); with an
        imported ``structure``, its plant (``rt.loop.structure.build_structure_plant``)."""
        if structure is not None:
            return self._get(("structure", structure, cfg.rt, cfg.plant, cfg.actuator),
                             lambda: build_structure_plant(cfg, structure))
        return self._get(("plant", cfg.rt, cfg.plant, cfg.actuator), lambda: build_plant(cfg))

    def force_tracking(self, cfg: Config, sensor: str) -> ForceTrackingDesign:
        """``design_force_tracking(cfg, sensor)``, once per distinct inputs (class docstring)."""
        t = cfg.tracking
        return self._get(("force_tracking", sensor, cfg.rt, cfg.actuator, cfg.sensors, t.pid_bandwidth_hz,
                          t.pid_phase_margin_deg), lambda: design_force_tracking(cfg, sensor))


def build_loop(cfg: Config, law: str | None = None, estimator: str = DEFAULT_ESTIMATOR,
               observer_cfg: Config | None = None, designs: Designs | None = None,
               structure: Structure | None = None) -> Loop:
    """Design time: plant, actuator, sensors, estimator, law and the force-tracking design for
    its sensor. The observer is designed from ``observer_cfg`` if given (a model that differs
    from the plant: robustness studies), else from cfg. ``designs``: the plant and force-tracking
    designs already made for other loops of the same study (``Designs``; None: made here).
    ``structure``: an imported structure (``rt.loop.structure``) as the plant instead of the
    configured beams; its observer is designed from the superelement
    (``frictionrt.observer.model.build_observer_model_se``).

    Raises ValueError (from the design) if the force-tracking loop would be unstable, or for an
    unknown estimator, or ConfigError if the structure has no adaptive screw."""
    require_adaptive_screw(cfg, "the closed loop (rt.loop.build_loop)")
    law = cfg.tracking.law if law is None else law
    estimator = estimator_of(estimator).value
    designs = Designs() if designs is None else designs
    plant = designs.plant(cfg, structure)
    sensor = SENSOR_OF_LAW[law]
    design = designs.force_tracking(cfg, sensor)
    amplitude = no_amplitude()
    if estimator == "observer":
        if observer_cfg is None:
            observer = design_observer(cfg, plant).params
        else:
            observer = design_observer(observer_cfg, None if structure is None else
                                       designs.plant(observer_cfg, structure)).params
    elif estimator == "amplitude":
        if structure is not None:
            raise ValueError("estimator amplitude with an imported structure: its schedule is the built-in beams' "
                             "only; use --estimator observer")
        od, amplitude = design_amplitude(cfg, plant) if observer_cfg is None else design_amplitude(observer_cfg)
        observer = od.params
    else:
        observer = _no_observer()
    if structure is not None and cfg.shaker.on:
        raise ValueError("shaker.on with an imported structure: the shaker stage is the built-in beams' only; "
                         "use shaker.armature_mass_kg=0 (an ideal force source)")
    check_shaker(cfg, plant)
    return Loop(cfg, law, plant, build_actuator(cfg), build_sensors(cfg), build_oracle(cfg), observer,
                build_prefilter(cfg), build_laws(cfg, law), design, sensor, loop_signals(plant), estimator,
                build_supervisor(cfg, estimator in OBSERVERS), build_shaker(cfg), plant.initial_state(cfg.actuator.F0_N),
                amplitude, structure)


def _no_observer() -> ObserverParams:
    """Observer parameters of size 0 (same types): the compiled loop's observer branch is not
    taken when the oracle runs."""
    e = np.zeros(0)
    return ObserverParams(A_d=np.zeros((0, 0)), B_dT=e, M=e, L=e, C_meas=e, C_u=e, C_v=e, CvA=e, beta=-1.0,
                          D_u=0.0, mu=0.0, alpha=1.0)


@dataclass
class LoopState:
    """Every state of the loop between two ticks: each component's state slots x*, the outputs
    of the previous tick that the next one reads (y*), the supervisor's state, the noise
    generator's state and the plant's contact-solver cache."""
    xs: np.ndarray
    ys: np.ndarray
    xo: np.ndarray
    xe: np.ndarray
    xl: np.ndarray
    yl: np.ndarray
    xq: np.ndarray
    xf: np.ndarray
    yf: np.ndarray
    sv: np.ndarray  # the supervisor's state (rt.loop.supervisor.SUPERVISOR_SLOTS)
    xa: np.ndarray
    ya: np.ndarray
    xp: np.ndarray
    yp: np.ndarray
    rng: np.ndarray
    plant_work: object  # PlantWork: its cached contact factors decide round-off, so they carry over
    xsh: np.ndarray     # the shaker's armature [x_a, x_a'] (plant.shaker), at rest 0
    k: int = 0  # the next tick to run

    def copy(self) -> LoopState:
        new = {n: (v.copy() if isinstance(v, np.ndarray) else v) for n, v in vars(self).items()}
        new["plant_work"] = type(self.plant_work)(*(a.copy() for a in self.plant_work))
        return LoopState(**new)


def controller_stages(loop: Loop, st: LoopState) -> tuple:
    """(est, law, sup, trk): the controller's arrays as ``frictionrt.rt.loop.tick._controller_tick`` takes
    them, the states those of ``st`` (advanced in place by the ticks), inputs, outputs and next
    states fresh scratch (but yl, yf: st's). The loop (``frictionrt.rt.loop.driver.run``), the replay and
    ``bench controller`` build them here. est ends with the amplitude-following blocks and their
    scratch (size 0 unless that kind runs)."""
    amp = no_amplitude() if loop.amplitude is None else loop.amplitude
    est = (st.xo, np.empty_like(st.xo), np.zeros(len(ORACLE_OUTPUTS)), np.zeros(2), loop.oracle,
           st.xe, np.empty_like(st.xe), np.zeros(len(OBSERVER_OUTPUTS)), np.zeros(2), loop.observer,
           amp, np.zeros(len(st.xe) if len(amp.grid) else 0))
    law = (st.xl, np.empty_like(st.xl), st.yl, np.zeros(2), loop.law_params)
    sup = (st.sv, np.zeros(len(SUPERVISOR_OUTPUTS)), loop.supervisor)
    trk = (st.xq, np.empty_like(st.xq), np.zeros(1), np.zeros(1), loop.prefilter,
           st.xf, np.empty_like(st.xf), st.yf, np.zeros(2), loop.design.params)
    return est, law, sup, trk


def initial_loop_state(loop: Loop, seed: int) -> LoopState:
    """At rest at F_N1 = F0 (0 V), every filter at its steady state; noise seeded with seed."""
    cfg = loop.cfg
    plant = loop.plant
    xa = actuator_initial_state(loop.actuator, V=cfg.actuator.V_min)
    ya = np.zeros(len(ACTUATOR_OUTPUTS))
    ya[0] = loop.actuator.F0 + loop.actuator.k_screw * xa[3]
    ai = actuator_output_index()
    ya[ai["F_strain_a"]] = ya[ai["F_cell_a"]] = ya[0]
    ys = np.zeros(len(SENSOR_OUTPUTS))
    si = sensor_output_index()
    ys[si["F_strain"]] = ys[si["F_cell"]] = ya[0]  # the readings at rest (noise-free)
    # the sensors' sampled-force filters carry dF_N1 in the loop's form: 0 at rest (g = g_ref)
    return LoopState(xs=sensors_initial_state(loop.sensors, F_N1=0.0), ys=ys,
                     xo=rest_state(loop.oracle, (0.0, 0.0)), xe=np.zeros(loop.observer.M.shape[0] + (loop.amplitude is not None and loop.amplitude.k_j > 0.0)), xl=np.zeros(len(LAWS_SLOTS)),
                     yl=np.zeros(len(LAWS_OUTPUTS)), xq=rest_state(loop.prefilter, (cfg.tracking.F_min_N,)),
                     xf=tracking_initial_state(ya[0]), yf=np.zeros(len(FORCE_TRACKING_OUTPUTS)),
                     sv=supervisor_initial_state(ys), xa=xa, ya=ya,
                     xp=loop.plant_rest.copy(), yp=np.zeros(len(plant.output_labels())),
                     rng=new_rng(seed), plant_work=plant.new_work(), xsh=np.zeros(2))
