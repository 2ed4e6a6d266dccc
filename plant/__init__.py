"""Plant: FE beams, contact and friction, Craig-Bampton, Newmark/Newton step, the piezo stack, the
sensors and the shaker (frictionrt).

Modules: ``fe_beam``, ``structure`` (the assembly, bolts and contact pairs), ``bolts`` (VDI 2230
cone), ``layout`` (where the contact points sit: by hand, or from the preloaded joint's stuck pressure and slip onset), ``tributary`` (what each contact point carries of the interface's area and loads), ``contact`` (Jenkins pairs), ``craig_bampton``, ``model`` (``build_plant``), ``newmark``
(the step kernel), ``simulate``, ``energy``, ``modes``, ``impulse``, ``measures`` (an FRF's peaks, half-power damping and weighted errors), ``linear_frf`` (the stuck
linear reference), ``harmonic_frf`` (the amplitude-dependent FRF by harmonic balance, with
``describing`` and ``aft``), ``actuator``, ``sensors``, ``shaker``. A leading underscore marks a compiled
kernel (``_plant_step``): kernels are imported from their modules. The names below are imported
on first use (rt/common/face.py).
"""
import frictionrt.rt.common  # noqa: F401  (numba's code-generation target and source-keyed cache, before any kernel compiles)
from frictionrt.rt.common.face import lazy_face  # noqa: E402

_EXPORTS = {
    "PlantModel": "frictionrt.plant.model", "build_plant": "frictionrt.plant.model", "preloaded_pairs": "frictionrt.plant.model", "stuck_frequencies_hz": "frictionrt.plant.model", "stuck_stiffness": "frictionrt.plant.model",
    "build_structure": "frictionrt.plant.structure",
    "impulse_test": "frictionrt.plant.impulse",
    "modes_summary": "frictionrt.plant.modes", "passive_resonance_hz": "frictionrt.plant.modes", "sliding_joint_hz": "frictionrt.plant.modes",
    "stuck_model": "frictionrt.plant.linear_frf", "point_accelerances": "frictionrt.plant.linear_frf",
    "harmonic_system": "frictionrt.plant.harmonic_frf", "harmonic_accelerances": "frictionrt.plant.harmonic_frf",
    "build_actuator": "frictionrt.plant.actuator",
    "build_sensors": "frictionrt.plant.sensors",
    "build_shaker": "frictionrt.plant.shaker",
}
__all__ = list(_EXPORTS)
__getattr__, __dir__ = lazy_face(__name__, _EXPORTS)
