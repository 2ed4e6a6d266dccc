"""The measurement chain that the virtual rig and the diagnosis share: plant -> sensors.

The rig (rt.discrepancy.rig) runs it on the true structure with the sensors' noise, the
diagnosis (rt.discrepancy.diagnose) on the nominal model with the noise switched off
(``quiet``), so that model and measurement go through the same filters. ``measure_impulse``
and ``measure_actuator`` give the channels of an impulse and of an actuator test
(``SIGNALS``); the noise of the channels that plant.sensors does not model is given here
(``FORCE_NOISE_N``, ``V_NOISE_V``, ``I_NOISE_A``) and added by the rig.
"""
from __future__ import annotations

import numpy as np

from frictionrt.plant.actuator import build_actuator, initial_state, output_index, run_actuator
from frictionrt.plant.model import PlantModel
from frictionrt.plant.sensors import build_sensors, run_sensors
from frictionrt.plant.simulate import run
from frictionrt.rt.common.config import Config, key_range, with_sets
from frictionrt.rt.common.noise import new_rng

FORCE_NOISE_N = 0.02                  # [N] rms, hammer force transducer
V_NOISE_V = 0.02                      # [V] rms, stack voltage monitor
I_NOISE_A = 1e-3                      # [A] rms, current monitor

SIGNALS = (("F_exc", "N", "rt"), ("a_tip_meas", "m/s^2", "sensors"), ("a_frf_meas", "m/s^2", "sensors"),
           ("v_tip_meas", "m/s", "sensors"), ("F_strain", "N", "sensors"), ("F_cell", "N", "sensors"),
           ("V_cmd", "V", "tracking"), ("V_a", "V", "actuator"), ("i", "A", "actuator"))
"""The recorded channels of every file of a campaign (name, unit, owner)."""
SENSOR_FIELDS = ("a_tip_meas", "a_frf_meas", "v_tip_meas", "F_strain", "F_cell")   # plant.sensors outputs


FIT_MARGIN = 1e-9
"""Relative margin of ``scale_bounds`` inside the configuration's range: v (1 - FIT_MARGIN) hi / v and
exp(ln f) stay <= hi after round-off (a few ulps, 1e-16 each)."""


def scaled_keys(cfg: Config, key: str) -> list[tuple[str, float]]:
    """The configuration keys that the calibration scale ``key`` (E, mu, k_t, modal_damping, c_v)
    multiplies, with their nominal values in ``cfg``: E every beam's, k_t the tangential stiffness per
    unit area. KeyError for another key."""
    if key == "E":
        return [(f"plant.beams.{b.name}.E", b.E) for b in cfg.plant.beams]
    table = {"mu": ("plant.interface.mu", cfg.plant.interface.mu),
             "k_t": ("plant.interface.k_t_area", cfg.plant.interface.k_t_area),
             "modal_damping": ("plant.modal_damping", cfg.plant.modal_damping),
             "c_v": ("actuator.c_v", cfg.actuator.c_v)}
    return [table[key]]


def scaled(cfg: Config, factors: dict[str, float]) -> Config:
    """``cfg`` with its nominal parameters multiplied by ``factors`` (keys of ``scaled_keys``: the
    rig's ``SCATTER``, the diagnosis' calibration scales; E scales every beam)."""
    return with_sets(cfg, [f"{k}={v * float(f)!r}" for key, f in factors.items() for k, v in scaled_keys(cfg, key)])


def scale_bounds(cfg: Config, key: str, lo: float, hi: float) -> tuple[float, float]:
    """A fit's range [lo, hi] of the scale ``key`` (x nominal) intersected with the factors f that the
    configuration accepts (rt.common.config.key_range of every key it scales, nominal v > 0:
    lo_c / v <= f <= hi_c / v), FIT_MARGIN inside them: a fit never leaves what ``scaled`` can build (an open
    lower end, lo_c = 0 exclusive, is inside every fit's range: their lower bounds are > 0)."""
    for k, v in scaled_keys(cfg, key):
        lo_c, hi_c, _ = key_range(cfg, k)
        if v <= 0.0:          # 0 x any factor: the nominal itself
            continue
        if lo_c is not None:
            lo = max(lo, lo_c / v * (1.0 + FIT_MARGIN))
        if hi_c is not None:
            hi = min(hi, hi_c / v * (1.0 - FIT_MARGIN))
    return lo, hi


def quiet(cfg: Config) -> Config:
    """``cfg`` with the sensor noise switched off (the model side of a comparison)."""
    return with_sets(cfg, ["sensors.acc_noise_rms=0.0", "sensors.strain_noise_N=0.0", "sensors.cell_noise_N=0.0"])


def hold_voltage(cfg: Config, F_N1: float) -> float:
    """V_cmd [V] that holds F_N1 [N] statically: F_N1 = F0 + c_v V."""
    a = cfg.actuator
    return min(max((F_N1 - a.F0_N) / a.c_v, a.V_min), a.V_max)


def stack_force(cfg: Config, V_cmd: float) -> float:
    """The adaptive screw's force [N] when the stack holds V_cmd [V] at rest (the actuator's initial state)."""
    pa, _ = _chain(cfg)
    _, Ya = run_actuator(pa, np.full(1, V_cmd), initial_state(pa, V=V_cmd))
    return float(Ya[0, output_index()["F_stack"]])


def measure_impulse(model: PlantModel, F_exc: np.ndarray, V_cmd: float, seed: int) -> dict[str, np.ndarray]:
    """The channels of an impulse test: the plant at the F_N1 the stack holds at V_cmd [V], driven by
    F_exc [N] per tick, read by the sensors of ``model.cfg`` (their noise from ``seed``).

    /sensors row k is the reading at t_k of the plant output of tick k - 1 (docs/data-format.md);
    V_a, i are the actuator's outputs at rest. Returns {signal name: array (n,)}, without F_exc."""
    cfg = model.cfg
    n = len(F_exc)
    pa, ps = _chain(cfg)
    _, Ya = run_actuator(pa, np.full(n, V_cmd), initial_state(pa, V=V_cmd))
    ia = output_index()
    Y, _, _ = run(model, F_exc, stack_force(cfg, V_cmd))
    io = model.output_index()
    U = np.empty((n, 4))
    U[0, :2] = 0.0
    U[1:, 0] = Y[:-1, io[f"abar_{sensor_point(cfg, 'tip')}"]]
    U[1:, 1] = Y[:-1, io[f"abar_{sensor_point(cfg, 'frf')}"]]
    U[:, 2] = Ya[:, ia["F_strain_a"]]
    U[:, 3] = Ya[:, ia["F_cell_a"]]
    _, Ys = run_sensors(ps, U, new_rng(seed))
    out = dict(zip(SENSOR_FIELDS, Ys.T))
    out.update(V_cmd=np.full(n, V_cmd), V_a=Ya[:, ia["V_a"]], i=Ya[:, ia["i"]])
    return out


_CHAINS: dict = {}


def _chain(cfg: Config):
    """(build_actuator(cfg), build_sensors(cfg)), memoised on what they read (cfg.actuator,
    cfg.sensors, cfg.rt): the diagnosis runs the chain for many plant parameters with one actuator."""
    key = (cfg.actuator, cfg.sensors, cfg.rt)
    if key not in _CHAINS:
        if len(_CHAINS) >= 16:
            _CHAINS.clear()
        _CHAINS[key] = (build_actuator(cfg), build_sensors(cfg))
    return _CHAINS[key]


def measure_actuator(cfg: Config, V_cmd: np.ndarray, seed: int) -> dict[str, np.ndarray]:
    """The channels of an actuator test (structure at rest): the chain driven by V_cmd [V] per tick,
    the bolt force sensors read by plant.sensors (noise from ``seed``). Returns {name: array (n,)}."""
    pa, ps = _chain(cfg)
    _, Ya = run_actuator(pa, V_cmd, initial_state(pa, V=float(V_cmd[0])))
    ia = output_index()
    U = np.zeros((len(V_cmd), 4))
    U[:, 2] = Ya[:, ia["F_strain_a"]]
    U[:, 3] = Ya[:, ia["F_cell_a"]]
    _, Ys = run_sensors(ps, U, new_rng(seed))
    out = dict(zip(SENSOR_FIELDS, Ys.T))
    out.update(V_cmd=np.asarray(V_cmd, float), V_a=Ya[:, ia["V_a"]], i=Ya[:, ia["i"]])
    return out


def sensor_point(cfg: Config, role: str) -> str:
    """Plant point name of the tip accelerometer ("tip") or the FRF accelerometer (plant.frf_point)."""
    return cfg.plant.frf_point if role == "frf" else "tip"
