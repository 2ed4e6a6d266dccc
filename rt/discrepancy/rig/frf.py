"""The virtual rig's FRF-file campaign (``frictionrt rig --frf-files``): what a lab
exports from low-level FRF measurements with the contact stuck, as FRF files (rt.log.frf_files,
docs/data-format.md "FRF files"), from the same "true" structure as ``rig`` writes time series of
(rt.discrepancy.rig.campaign.true_structure: the same scatter draw and hidden effect for the same seed).

One test per F_N1 level (default 40, 100, 300 N): the stack holds F_N1 within ``HOLD_REL``
(relative rms; the sidecar gives the held value, as a lab's load-cell mean); the accelerances of
both accelerometers are the continuous FRF of the stuck linearised plant at that F_N1
(plant.linear_frf's model, plant.linear_frf.point_accelerances: the physical structure, no time
step), on the lines
``FREQ_HZ`` (0.25 Hz from 4 to 1600 Hz, 6385 lines, like an analyser's 6400-line zoom), with
complex Gaussian noise per line of rms ``NOISE_REL`` |H| (the random error of an H1 estimate with
coherence ~0.99 over a few averages) plus ``NOISE_FLOOR`` (accelerometer noise over the force:
it fills the deepest antiresonances). The tests are written alternately as CSV and UFF
(frf_01.csv, frf_02.uff, frf_03.csv), so every campaign exercises both readers. Nothing in a
file names or parameterises the effect: the sidecar gives kind "frf", the excitation and sensor
positions, the held F_N1, the force amplitude and a description that is the same for every
effect.

A structure without an adaptive screw (ordinary bolts only, or the bare beam: docs/plant.md 5.3)
has no F_N1 to hold: one test, frf_01.csv, with F_N1_N = 0 in its sidecar.

The file kinds a lab has (arguments of ``make_frf_campaign``, defaults as above): the
response as ``quantity`` (rt.log.frf_files.QUANTITIES: H_a / (i w)^(2 - k)), the excitation as a
drive voltage with a force scale s [N/V] (H per volt = s H per newton: a voltage-driven shaker
without force transducer; the noise floor is scaled alike; with a shaker in the truth, armature mass
> 0, its force per drive ``drive_force_ratio`` multiplies H: the two-port of plant.shaker in the
configured amplifier mode, so ``--effect shaker_interaction`` shows per volt only), and other sensors {name: (beam, x_m)}
at massless points added to the true structure (``add_points``) instead of the two accelerometers.
"""
from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import Config, Point, adaptive_screw, with_sets
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.log.data_format import ACCELEROMETER_POINTS
from frictionrt.rt.log.frf_files import FORMAT, FRFTest, from_accelerance, write_frf_csv, write_frf_uff
from frictionrt.plant.linear_frf import point_accelerances
from frictionrt.plant.shaker import force_ratio
from frictionrt.rt.discrepancy.chain import sensor_point
from frictionrt.rt.discrepancy.rig.campaign import FN1_LEVELS_N, new_folder, true_structure

FREQ_HZ = 4.0 + 0.25 * np.arange(6385)   # [Hz] 4 .. 1600 Hz
NOISE_REL = 0.01                         # complex noise rms relative to |H|
NOISE_FLOOR = 2e-3                       # [(m/s^2)/N] complex noise rms floor
HOLD_REL = 0.01                          # relative rms of the held F_N1 about its level
FORCE_N = 1.0                            # [N] excitation force amplitude (low level: contact stuck)
SHAKER = "shaker_interaction"            # the effect FRF files show only per drive volt (no force measured)


def drive_force_ratio(cfg: Config, model, F_N1: float, freq_hz: np.ndarray) -> np.ndarray:
    """F_exc / drive (complex) of ``cfg``'s shaker (plant.shaker.force_ratio, in its amplifier's mode) on the
    stuck structure ``model`` at F_N1 [N]: its driving-point receptance R = H_a / (i omega)^2 at the
    excitation point (plant.linear_frf.point_accelerances)."""
    ha = point_accelerances(model, {"drive": cfg.plant.excitation_point}, F_N1, freq_hz)["drive"]
    return force_ratio(cfg, freq_hz, -ha / (2 * np.pi * np.asarray(freq_hz, float)) ** 2)


def sensor_points(cfg: Config) -> dict[str, str]:
    """Plant point of each accelerometer of the measurement format."""
    return {s: sensor_point(cfg, role) for s, role in ACCELEROMETER_POINTS.items()}


def add_points(cfg: Config, points: dict[str, tuple[str, float]]) -> Config:
    """``cfg`` with a massless point {name: (beam, x_m)} added for each entry (a mesh node there)."""
    if not points:
        return cfg
    new = tuple(Point(name=n, beam=b, x_m=float(x)) for n, (b, x) in points.items())
    return with_sets(dataclasses.replace(cfg, plant=dataclasses.replace(cfg.plant, points=cfg.plant.points + new)), [])


def frf_meta(cfg: Config, F_N1: float, description: str, sensors: dict[str, str] | None = None, **extra) -> dict:
    """The sidecar of a rig FRF test on structure ``cfg`` at the held F_N1 [N]; ``sensors``
    {sensor: point} (default: the accelerometers), ``extra`` optional sidecar keys (quantity, ...)."""
    pts = {p.name: p.x_m for p in cfg.plant.points}
    return {"format": FORMAT, "kind": "frf", "excitation_x_m": pts[cfg.plant.excitation_point],
            "sensor_positions_m": {s: pts[p] for s, p in (sensors or sensor_points(cfg)).items()},
            "F_N1_N": F_N1, "amplitude_n": FORCE_N, "description": description} | extra


def make_frf_campaign(out_dir: str | os.PathLike, effect: str = "none", strength: float | None = None,
                      seed: int = 0, cfg: Config | None = None, levels_n=FN1_LEVELS_N, quantity: str = "accelerance",
                      force_scale_N_per_V: float | None = None,
                      sensors: dict[str, tuple[str, float]] | None = None,
                      other_form: tuple[str, ...] = (), refine: int | None = None) -> list[Path]:
    """Write the FRF tests (module docstring) into the new folder ``out_dir`` (a temporary folder,
    then renamed). Arguments as rt.discrepancy.rig.campaign.make_campaign; ``quantity`` of the files,
    ``force_scale_N_per_V`` (given: the excitation is a drive voltage, H per volt = s H per
    newton), ``sensors`` {name: (beam, x_m)} instead of the accelerometers; returns the data files
    written. ValueError for an effect linear FRFs cannot show (``Effect.visible_in_frf_files``)."""
    if effect != "none" and not get(effect).visible_in_frf_files() and not (
            effect == SHAKER and force_scale_N_per_V is not None):
        if effect == SHAKER:
            raise ValueError(f"effect {effect!r}: with the force measured at the stinger's tip the FRFs per newton do "
                             "not show the shaker; write FRFs per drive volt (--force-scale N_PER_V)")
        raise ValueError(f"effect {effect!r} leaves the structure linearised with the contact stuck unchanged "
                         "(it acts through slip or the actuator), so linear FRF files cannot show it; write FRFs "
                         "at several force levels (--levels) or a time-series campaign (rig without --frf-files)")
    rng = np.random.default_rng(seed)
    true = true_structure(cfg, effect, strength, rng, other_form, refine)
    held = adaptive_screw(true) is not None
    names = []
    true = add_points(true, sensors or {})
    points = {s: s for s in sensors} if sensors else sensor_points(true)
    extra = ({"quantity": quantity} if quantity != "accelerance" else {}) | (
        {"excitation": "drive_voltage", "amplitude_n": None} if force_scale_N_per_V is not None else {})
    gain = 1.0 if force_scale_N_per_V is None else float(force_scale_N_per_V)
    with threadpool_limits(1), new_folder(out_dir) as tmp:
        model = build_plant(true)
        for j, level in enumerate(levels_n if held else (0.0,)):
            F_N1 = round(level * (1.0 + HOLD_REL * rng.standard_normal()), 2) if held else 0.0
            H = point_accelerances(model, points, F_N1, FREQ_HZ)
            if force_scale_N_per_V is not None and true.shaker.on:
                ratio = drive_force_ratio(true, model, F_N1, FREQ_HZ)
                H = {s: h * ratio for s, h in H.items()}
            for s, h in H.items():
                z, w = rng.standard_normal((2, len(h), 2)) @ np.array([1.0, 1j]) / np.sqrt(2)
                H[s] = gain * from_accelerance(h * (1.0 + NOISE_REL * z) + NOISE_FLOOR * w, FREQ_HZ, quantity)
            name = f"frf_{j + 1:02d}" + (".uff" if j % 2 else ".csv")
            drive = (f"{FORCE_N:g} N" if force_scale_N_per_V is None
                     else "shaker driven by a voltage, no force transducer")
            held_text = f"adaptive screw held at about {level:g} N by the stack" if held else "no adaptive screw"
            test = FRFTest(Path(name).stem, FREQ_HZ, H, None, None, frf_meta(
                true, F_N1, f"low-level FRF, force at the excitation point (contact stuck), {drive}, {held_text}",
                points, **extra))
            (write_frf_uff if j % 2 else write_frf_csv)(tmp / name, test)
            names.append(name)
    return [Path(out_dir) / n for n in names]
