"""The effects library of the discrepancy workflow (docs/discrepancy.md): physical effects a real
test rig has and the nominal model may lack, each with its parameter and a documented signature
(what it does to the measurements), as a registry ``EFFECTS`` {name: Effect}.

An implemented effect maps (configuration, strength) to the configuration with the effect added,
``effect.apply(cfg, s) -> Config``; strength 0 (or the nominal value, for ``current_limit``) is the
nominal model. The virtual rig (rt.discrepancy.rig) hides an effect in a measurement campaign this way, and the
diagnosis (rt.discrepancy.diagnose) fits the strength of each implemented candidate jointly with the nominal
parameters. All nine effects of this version are implemented; an effect entered before its kernel
code exists (no ``apply``: ``implemented`` False) is shown by ``frictionrt rig --list``, refused by
``rig --effect`` and listed under ``not_tried`` by ``diagnose``. Adding one: docs/discrepancy.md,
"How to add an effect".
"""
from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable
from typing import NamedTuple

from frictionrt.rt.common.config import Config, adaptive_screw, with_sets


class Parameter(NamedTuple):
    """The effect's strength parameter: name (unit in it), unit, default ("moderate") strength, and
    the bounds the diagnosis fits it within."""
    name: str
    unit: str
    default: float
    lo: float
    hi: float


@dataclasses.dataclass(frozen=True)
class Effect:
    name: str
    description: str           # the physical model
    signature: str             # what it does to the measurements (the diagnosis looks for this)
    parameter: Parameter
    channel: str               # "structure" (impulse tests), "actuator" (voltage ramps) or "stepsine" (F_amp/drive)
    nominal: float             # the strength at which the model is the nominal one
    _apply: Callable[[Config, float], Config] | None = None
    stuck_linear: bool = True  # it changes the structure linearised with the contact stuck (so the
                               # linear FRFs of FRF-file input can show it); False: only slip shows it
    form: bool = False         # a model-form candidate (the structure's boundary, joint or attachments:
                               # reported as "model form", apart from the effects)
    log_scale: bool = False    # the fits move ln(strength) (a stiffness ratio over decades; bounds > 0)

    def visible_in_frf_files(self) -> bool:
        """Whether linear (stuck-contact) FRF files can show the effect (rt.discrepancy.diagnose.frf, rt.discrepancy.rig.frf)."""
        return self.channel == "structure" and self.stuck_linear

    @property
    def implemented(self) -> bool:
        return self._apply is not None

    def apply(self, cfg: Config, strength: float) -> Config:
        """``cfg`` with the effect at ``strength`` [parameter.unit] added (validated).
        ValueError if the effect is not implemented or the strength is outside its bounds."""
        if self._apply is None:
            raise ValueError(f"effect {self.name!r} is not implemented yet (it needs new kernel code: "
                             "docs/discrepancy.md)")
        p = self.parameter
        if not p.lo <= strength <= p.hi:
            raise ValueError(f"effect {self.name}: strength {strength:g} {p.unit} outside [{p.lo:g}, {p.hi:g}]")
        return self._apply(cfg, float(strength))

    def to_json(self) -> dict:
        p = self.parameter
        return {"name": self.name, "implemented": self.implemented, "channel": self.channel,
                "parameter": p.name, "unit": p.unit, "default_strength": p.default, "bounds": [p.lo, p.hi],
                "nominal": self.nominal, "visible_in_frf_files": self.visible_in_frf_files(),
                "kind": "model form" if self.form else "effect",
                "description": self.description, "signature": self.signature}


# --- configuration-level effects ------------------------------------------------------------------

ACCELEROMETER_FIELDS = {"a_frf_meas": "frf", "a_tip_meas": "tip"}
"""The accelerometers of the measurement format and the plant points they sit on."""


def _accelerometer_mass(cfg: Config, m: float) -> Config:
    return with_sets(cfg, [f"plant.points.{pt}.mass_kg={m!r}" for pt in ACCELEROMETER_FIELDS.values()])


def _clamp_compliance(cfg: Config, c: float) -> Config:
    # clamps have no name, so --set cannot address them: replace the field on every clamp;
    # below 1e-12 rad/(N m) (stiffer than 1e12 N m/rad) the clamp is rigid (and the FE solve well conditioned)
    c = c if c >= 1e-12 else 0.0
    clamps = tuple(dataclasses.replace(cl, rot_compliance_rad_per_Nm=c) for cl in cfg.plant.clamps)
    return with_sets(dataclasses.replace(cfg, plant=dataclasses.replace(cfg.plant, clamps=clamps)), [])


def _clamp_translation(cfg: Config, c: float) -> Config:
    # below 1e-12 m/N (stiffer than 1e12 N/m) the clamp holds w rigidly
    c = c if c >= 1e-12 else 0.0
    clamps = tuple(dataclasses.replace(cl, trans_compliance_m_per_N=c) for cl in cfg.plant.clamps)
    if not clamps:
        raise ValueError("clamp_translation is a compliance of the clamps and this structure has none (plant.clamps)")
    return with_sets(dataclasses.replace(cfg, plant=dataclasses.replace(cfg.plant, clamps=clamps)), [])


def _joint_compliance(cfg: Config, s: float) -> Config:
    i = cfg.plant.interface
    if not i.enabled:
        raise ValueError("joint_compliance is the stiffness of the interface and this structure has none "
                         "(plant.interface.enabled = false)")
    return with_sets(cfg, [f"plant.interface.k_n_area={i.k_n_area * s!r}", f"plant.interface.k_t_area={i.k_t_area * s!r}"])


def attach_point(cfg: Config) -> str:
    """The point of the attached_mass and attached_spring candidates: diagnosis.attach_point, else the
    excitation point."""
    return cfg.diagnosis.attach_point or cfg.plant.excitation_point


def _attached(field: str, cfg: Config, value: float) -> Config:
    name = attach_point(cfg)
    point = next(p for p in cfg.plant.points if p.name == name)
    return with_sets(cfg, [f"plant.points.{name}.{field}={getattr(point, field) + value!r}"])


def _moving_mass(cfg: Config, m: float) -> Config:
    screw = adaptive_screw(cfg)
    if screw is None:
        raise ValueError("moving_mass is a mass on the adaptive screw and this structure has none "
                         "(no plant.screws entry with adaptive = true)")
    return with_sets(cfg, [f"plant.screws.{screw.name}.mass_kg={m!r}"])


def _set_key(key: str, cfg: Config, value: float) -> Config:
    """``cfg`` with the configuration key ``key`` set to ``value`` (an effect that is one setting)."""
    return with_sets(cfg, [f"{key}={value!r}"])


def _setting(key: str) -> Callable[[Config, float], Config]:
    """The ``apply`` of an effect that is the configuration key ``key`` (picklable: the diagnosis
    sends effects to worker processes)."""
    return functools.partial(_set_key, key)


_EFFECTS = (
    Effect("accelerometer_mass",
           "mass loading: a point mass m at each accelerometer (the frf and tip points), the sensor's "
           "housing, base and cable; M += m at the point's w DOF",
           "frequencies drop by m phi(x)^2 of each mode at the two sensor points (0.02 kg: modes 1-8 -1.7, -2.2, "
           "-2.1, -2.9, -1.0, -0.3, -1.8, -0.9 %): mode 6 (and 5) barely move, unlike a lower E; the frf "
           "FRF's antiresonances drop 1-3 % except the one at 880 Hz, the tip FRF's at 285 and 895 Hz stay; "
           "the same at every F_N1",
           Parameter("mass_kg", "kg", 0.02, 0.0, 0.2), "structure", 0.0, _accelerometer_mass),
    Effect("clamp_compliance",
           "a rotational spring of compliance c at the fixture (plant.clamps): M_clamp = w'(0) / c instead of "
           "a rigid clamp",
           "frequencies drop for the modes with a large root bending moment (3e-5 rad/(N m): modes 1-3, 5, 6 "
           "-2.7 %), less for mode 4 (-1.6 %), little for modes 7, 8 (-0.4 %); antiresonances of both FRFs "
           "drop up to 5 % (frf 267, 880 Hz; tip 285, 895 Hz), those above 1.3 kHz stay; the same at every F_N1",
           Parameter("rot_compliance_rad_per_Nm", "rad/(N m)", 3e-5, 0.0, 5e-4), "structure", 0.0,
           _clamp_compliance, form=True),
    Effect("moving_mass",
           "actuator moving mass: the piezo stack's moving part, screw head and washers as a point mass m on the "
           "upper (damper) beam at the adaptive screw",
           "frequencies of the modes that move the damper beam at the adaptive screw drop (0.05 kg: mode 1 "
           "-2.0 %, mode 4 -1.7 %, mode 8 -1.1 %, mode 5 -0.7 %), modes 2, 3, 6, 7 stay within 0.3 %; "
           "antiresonances near 22-33 Hz and 330-490 Hz drop 1-2 %; mode 7 -0.1 % at 100 N but -1.0 % at 300 N",
           Parameter("mass_kg", "kg", 0.05, 0.0, 0.5), "structure", 0.0, _moving_mass),
    Effect("current_limit",
           "amplifier current limit I_max lower than the nominal 1 A: the stack voltage slews at I_max / C "
           "(C = actuator.capacitance_F) when a command asks for more",
           "fast voltage ramps: the measured current plateaus at +-I_max, V_a and the bolt force lag the "
           "command with a constant slope; slow ramps and the impulse tests are unchanged",
           Parameter("current_limit_A", "A", 0.3, 0.02, 1.0), "actuator", 1.0, _setting("actuator.current_limit_A")),
    Effect("piezo_hysteresis",
           "rate-independent hysteresis of the stack: free elongation d (V_a - h) with the Bouc-Wen state "
           "h' = A V_a' - beta |V_a'| h (n = 1, gamma = 0), beta = 2 / (V_max - V_min), A set by the loop "
           "width w: quasi-statically F_N1 = F0 + c_v (V_a - h) (plant/actuator.py)",
           "bolt force vs V_a on the ramps is a loop: the down branch lies above the up branch by w c_v "
           "(V_max - V_min) at mid range (0.1: 56 N of the 560 N swing), the up branch is concave, and the "
           "force after 150 -> 0 V stays 44 N above F0 (-c_v h, h = -11.9 V); the same on every ramp rate; V_a, i "
           "and the impulse tests unchanged",
           Parameter("hysteresis_width_rel", "-", 0.1, 0.0, 0.3), "actuator", 0.0,
           _setting("actuator.hysteresis_width_rel")),
    Effect("preload_creep",
           "creep of the screw thread's preload: after a step of the stack's force F_N1 relaxes by c of the "
           "step per decade, F_step (1 - c log10(1 + t / tau0)), tau0 = 1 ms, as a Prony series of five "
           "first-order states (tau_j = 1 ms .. 10 s) on the stack's input; c_v stays the static gain "
           "(plant/actuator.py)",
           "the bolt force drifts at constant voltage on the ramps' 30 ms holds (0.02: F_cell 48 N above the "
           "static F0 + c_v 150 V 2 ms into the 150 V hold, 12 N lower by its end; after 150 -> 0 V 13 N below "
           "F0, 3 N below at the end), i.e. a log-time relaxation a calibrated c_v cannot follow and of the "
           "opposite sign after the down ramp to the piezo hysteresis' offset; nearly the same after every ramp "
           "(drift 12.4 N after the 0.3 ms ramp, 10.9 N after the 3 ms one); V_a, i and the impulse tests "
           "(held V) unchanged",
           Parameter("creep_per_decade", "-", 0.02, 0.0, 0.1), "actuator", 0.0, _setting("actuator.creep_per_decade")),
    Effect("micro_slip",
           "micro-slip: an Iwan element per contact pair instead of one Jenkins element, N = "
           "plant.interface.iwan_elements (6) Jenkins elements in parallel with stiffness k_t / N and slip limits "
           "(mu f_n / N)(1 + a (2 (i + 1/2)/N - 1)): the same stuck stiffness and macro-slip force, micro-slip "
           "from (1 - a (N-1)/N) mu f_n on (plant/contact.py)",
           "the stuck plant is unchanged (same k_t: stuck frequencies and the 300 N test's modes within 0.05 %); "
           "the FRFs change through damping where pairs are near their slip limit (0.5, 50 N hammer: mode 3 "
           "damping at 100 N 1.29 -> 1.39 %, mode 2 0.102 -> 0.119 %, at 300 N mode 3 0.148 -> 0.158 %), "
           "0.45 / 0.61 / 0.63 dB rms over 4-1600 Hz at 40 / 100 / 300 N (0.9: 0.32 / 1.03 / 1.30), as much as "
           "mu +5 % (0.46 / 0.85 / 0.45); below macro-slip a steady 0.5 N sine at mode 3 (100 N) loses 17 % of "
           "its input to friction where the Jenkins pairs stay stuck (0 %)",
           Parameter("iwan_spread", "-", 0.5, 0.0, 0.95), "structure", 0.0,
           _setting("plant.interface.iwan_spread"), stuck_linear=False),
    Effect("shaker_interaction",
           "shaker-structure interaction: the shaker's armature (mass m on its flexure, 20 Hz, 5 %) drives "
           "the excitation point through a stinger (5e6 N/m, 20 N s/m); the force transducer at the stinger's tip "
           "measures F_exc = k_s (x_a - w_exc) + c_s (x_a' - w_exc') instead of the drive (plant/shaker.py); "
           "the coil's electrical port (R, L, Bl) in the amplifier's mode (shaker.amplifier: current, or voltage "
           "with the back-EMF damping Bl^2 / R at the armature) shapes the force per drive volt of FRF files "
           "without a force, where the FRF-file diagnosis fits it (rt.discrepancy.diagnose.frf.fit_shaker_frf)",
           "step-sine tests: F_amp / drive dips at the structure's resonances and rises just below them "
           "(0.1 kg, 10 N, nominal structure at 100 N: 0.58 at the 203 Hz mode-3 peak, 1.54 at 194 Hz; 0.49 at "
           "373 Hz, 1.68 at 364 Hz), the amplitude controller raises the drive there; away from the modes "
           "0.87-0.98 (120-300 Hz), 1.14-1.27 at 500 Hz, 6-15 at 1250 Hz (armature on the stinger, ~1.2 kHz); "
           "the force has harmonics at a slipping resonance (THD 1.49 at 373 Hz, 0.18 at 203 Hz; 0.001 stuck, "
           "0 ideal); a / F_exc within 0.5 % off the resonances (force measured at the structure), up to 25 % "
           "at the slipping peaks (the force's harmonics); impulse tests unchanged (no shaker on the hammer "
           "tests)",
           Parameter("armature_mass_kg", "kg", 0.1, 0.0, 1.0), "stepsine", 0.0, _setting("shaker.armature_mass_kg")),
    Effect("stribeck",
           "velocity-dependent friction (Stribeck) at the contact pairs: mu(v) = mu_k (1 + s exp(-(v / v_s)^2)), "
           "s the static excess (mu_s = (1 + s) mu_k), v the pair's tangential surface velocity at the start of "
           "each substep, v_s = plant.interface.stribeck_velocity_m_s (1 mm/s)",
           "modes 2-5 move only in the slipping impulse tests (0.3, 50 N hammer; at 300 N within 0.05 Hz, where the "
           "lightly loaded pairs still slip and change the damping; FRFs 1.7 / 2.2 / 2.6 dB rms off at 40 / 100 / "
           "300 N): "
           "pairs stick longer (breakaway at mu_s) so the joint modes rise, at 40 N mode 2 +1.0 % (72.3 -> 73.0 Hz), "
           "at 100 N mode 3 +1.4 % (218.5 -> 221.6 Hz), but once sliding the pairs dissipate at mu_k: mode 3 "
           "damping at 100 N stays 1.26 % (nominal 1.29 %) where a 30 % higher mu that gives the same shift "
           "(223.0 Hz) leaves 0.28 %; mode 4 damping at 100 N 1.53 -> 0.32 %",
           Parameter("static_excess_rel", "-", 0.3, 0.0, 1.0), "structure", 0.0,
           _setting("plant.interface.static_excess"), stuck_linear=False),
)

EFFECTS: dict[str, Effect] = {e.name: e for e in _EFFECTS}

# --- model-form candidates ------------------------------------------------------------------------
# The structure's form where a nominal model is commonly wrong: the fixture, the joint, attachments.
# Their strengths' bounds are the ranges real set-ups have (docs/discrepancy.md "Model-form candidates"
# gives the sources); each is a rig truth (``rig --effect NAME``) and a candidate of FRF-file input
# (rt.discrepancy.diagnose.frf, diagnosis.model_form). clamp_compliance (above, an effect since its first
# version) is one of them too (form=True).

_FORMS = (
    Effect("clamp_translation",
           "a transverse spring of compliance c at the fixture (plant.clamps[].trans_compliance_m_per_N): the "
           "clamp's w held by a spring 1 / c instead of rigidly (a bench vice's jaws and slide, a bolted block "
           "on a table)",
           "the higher modes drop most, the first little (1e-7 m/N: modes 1-8 -0.03, -0.43, -1.3, -1.5, -4.0, "
           "-8.6, -5.4, -4.6 %), unlike a rotational clamp compliance, which moves modes 1-3 alike",
           Parameter("trans_compliance_m_per_N", "m/N", 1e-7, 0.0, 1e-6), "structure", 0.0, _clamp_translation,
           form=True),
    Effect("joint_compliance",
           "the bolted connection more compliant than the contact model: the interface's normal and tangential "
           "stiffness per area (plant.interface.k_n_area, k_t_area) times s < 1, its bending stiffness (the "
           "normal springs' lever arms) and its shear stiffness alike",
           "the joint's modes drop, the clamp's barely (0.03: modes 1-8 -0.22, -4.5, -12.8, -10.2, -4.3, -8.7, "
           "-7.5, -6.4 %): mode 3 (the damper beam on the joint) most, mode 1 least",
           Parameter("stiffness_rel", "-", 0.03, 1e-3, 1.0), "structure", 1.0, _joint_compliance,
           form=True, log_scale=True),
    Effect("attached_mass",
           "a point mass m added at diagnosis.attach_point (default the excitation point): a force transducer, "
           "a stinger's moving part, a cable clamp",
           "the modes with motion at the point drop by about m phi(x)^2 / 2 of their modal mass (0.05 kg at the "
           "excitation point: modes 1-8 -0.25, -2.5, -0.5, -1.0, -2.3, -0.9, -1.0, -0.9 %)",
           Parameter("mass_kg", "kg", 0.05, 0.0, 0.5), "structure", 0.0, functools.partial(_attached, "mass_kg"),
           form=True),
    Effect("attached_spring",
           "a transverse spring k to the ground added at diagnosis.attach_point (default the excitation point): "
           "a stinger's bending, a support, a suspension",
           "the low modes with motion at the point rise, the high ones stay (1e4 N/m at the excitation point: "
           "mode 1 +12 %, mode 2 +2.4 %, modes 3-8 within 0.05 %)",
           Parameter("stiffness_N_m", "N/m", 1e4, 0.0, 1e5), "structure", 0.0,
           functools.partial(_attached, "stiffness_N_m"), form=True),
)

MODEL_FORMS: dict[str, Effect] = {e.name: e for e in _FORMS}


def implemented() -> list[Effect]:
    """The effects that can be applied (configuration-level) this version."""
    return [e for e in _EFFECTS if e.implemented]


def get(name: str) -> Effect:
    """The effect or model-form candidate called ``name``; ValueError naming the known ones otherwise."""
    if name in MODEL_FORMS:
        return MODEL_FORMS[name]
    if name not in EFFECTS:
        raise ValueError(f"unknown effect {name!r}; known: {', '.join(EFFECTS)}, and the model-form candidates "
                         f"{', '.join(MODEL_FORMS)} (frictionrt rig --list)")
    return EFFECTS[name]


def model_forms() -> list[Effect]:
    """The model-form candidates beyond the effects library (``MODEL_FORMS``)."""
    return list(_FORMS)


def effects_of(effect) -> tuple[Effect, ...]:
    """The candidate effects of a fit's ``effect`` argument: None, one Effect, or a tuple of them (a fit of
    two candidates at once, rt.discrepancy.diagnose.frf.next_candidate)."""
    return () if effect is None else tuple(effect) if isinstance(effect, tuple) else (effect,)


def effect_names(effect) -> list[str]:
    """The strength names of ``effects_of(effect)``."""
    return [e.name for e in effects_of(effect)]
