"""The virtual test rig: a measurement campaign in the measurement format
(docs/data-format.md) from a "true" structure that differs from the nominal model by parameter
scatter and, optionally, one hidden effect of the library (rt.discrepancy.effects).

Campaign (``make_campaign``):

* impulse tests, one per F_N1 level (default 40, 100, 300 N): the stack holds the voltage
  V = (F_N1 - F0) / c_v, a hammer hits the excitation point (half-sine, peak ~50 N and contact
  ~0.5 ms, both varying by +-10 % from hit to hit, after a 10 ms pre-trigger); recorded for
  ``record_s``: F_exc (force transducer, noise ``FORCE_NOISE_N``), both accelerometers and the
  tip velocity, both bolt force sensors (plant.sensors: anti-alias filter, noise, ADC), V_cmd,
  V_a and i (noise ``V_NOISE_V``, ``I_NOISE_A``);
* actuator characterisation, structure at rest: V_cmd ramps 0 -> 150 V -> 0 V over each of
  ``RAMPS_S``, each end held ``HOLD_S`` (``ramp_command``: long enough for the bolt force's
  creep to show, 18 N at the default strength), recorded with the same channels (F_exc and the
  accelerations are sensor noise).

Realism: nominal parameters scatter by ``SCATTER`` (relative standard deviation, normal draws cut
at 2 sigma, one draw per campaign from the seed); every channel has sensor noise; records are
finite. Nothing in a file names or parameterises the effect: the metadata is the ``signals`` and
``test`` records (kind, excitation point, sensor positions, law none, amplitude, duration, a
description that is the same for every effect) and a ``frictionrt`` record with only the UTC start of
the test, ``start_utc`` (no configuration: a measurement does not know its model). ``--effect none`` gives the scattered nominal structure.

The measurement chain (plant -> sensors: ``measure_impulse``, ``measure_actuator``) is
rt.discrepancy.chain, which the diagnosis runs on the nominal model with the noise switched off,
so that model and measurement go through the same filters.
"""
from __future__ import annotations

import json
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from frictionrt.plant.impulse import hammer_force
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import Config, refined_sets, require_adaptive_screw, with_sets
from frictionrt.rt.discrepancy.chain import (FORCE_NOISE_N, I_NOISE_A, SIGNALS, V_NOISE_V, hold_voltage, measure_actuator,
                                  measure_impulse, scaled)
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.log.mcap_log import utc_now
from frictionrt.rt.log.writer import McapBlockWriter

FN1_LEVELS_N = (40.0, 100.0, 300.0)   # impulse tests: bolt force levels [N]
RAMPS_S = (0.3e-3, 1e-3, 3e-3)        # actuator tests: 0 -> V_RAMP_V ramp durations [s]
V_RAMP_V = 150.0                      # [V] ramp height
HOLD_S = 0.03                         # [s] each ramp's end held: 1.5 decades of creep past tau0 = 1 ms
HAMMER_PEAK_N = 50.0                  # [N] nominal hammer peak
HAMMER_CONTACT_S = 0.5e-3             # [s] nominal contact time
PRETRIGGER_S = 0.01                   # [s] record before the hit
SCATTER = {"E": 0.02, "mu": 0.05, "k_t": 0.05, "modal_damping": 0.10, "c_v": 0.03}
"""Relative standard deviation of the nominal parameters from campaign to campaign."""
MODEL_FORM_BEAMS = (1.005, 0.995)     # beam k's height and density x these in turn (cycled over the beams)
MODEL_FORM_TAU = 2.0                  # interface dashpot time constant x this
MODEL_FORM_PARTS = ("mesh", "pitch", "substeps", "damping", "beams")
"""The parts of ``model_form``, each selectable alone (``rig --model-form PARTS``)."""
REFINED_PARTS = ("mesh", "pitch", "substeps")
"""The parts that ``model_form``'s ``refine`` factor sets (the discretisation's)."""


def model_form_parts(text: str | None) -> tuple[str, ...]:
    """The parts named by ``text`` ("all" or a comma-separated subset of ``MODEL_FORM_PARTS``; None:
    none, the nominal's form). ValueError naming an unknown part and the choices."""
    if text is None:
        return ()
    if text.strip() == "all":
        return MODEL_FORM_PARTS
    parts = tuple(dict.fromkeys(t.strip() for t in text.split(",")))
    bad = [t for t in parts if t not in MODEL_FORM_PARTS]
    if bad:
        raise ValueError(f"model form part {bad[0]!r} is not one of {', '.join(MODEL_FORM_PARTS)}; "
                         "give all or a comma-separated subset, e.g. substeps,pitch")
    return parts


def model_form_refine(text: str | None, parts: tuple[str, ...]) -> int | None:
    """The refinement factor of ``rig --model-form PARTS --refine R`` (``model_form``'s ``refine``) from
    ``text`` (None: none given, today's form). ValueError naming the value and the fix when it is not a
    whole number of at least 2, or when ``parts`` hold none of ``REFINED_PARTS`` (nothing to refine)."""
    if text is None:
        return None
    try:
        r = int(text.strip())
    except ValueError:
        r = None
    if r is None or r < 2:
        raise ValueError(f"refine factor {text!r} is not a whole number >= 2; give e.g. 2 (half the pitch and "
                         "element length, four times the substeps)")
    if not set(parts) & set(REFINED_PARTS):
        raise ValueError(f"refine factor {r} refines the parts {', '.join(REFINED_PARTS)}, and the model form "
                         f"{','.join(parts) or '(none)'} has none of them; add one (or all) to --model-form, "
                         "or drop --refine")
    return r


def model_form(cfg: Config, parts: tuple[str, ...] = MODEL_FORM_PARTS, refine: int | None = None) -> Config:
    """A truth of another model form than ``cfg`` (``rig --model-form``, docs/discrepancy.md "Model
    form"), made of ``parts`` (``MODEL_FORM_PARTS``): "mesh" a finer element length, "pitch" a finer
    contact pitch (the contact is per unit area: the same physical joint, sampled more finely),
    "substeps" more plant substeps per one of ``cfg``'s, "damping" the interface dashpots' tau_s x
    ``MODEL_FORM_TAU``, "beams" beams that are not the nominal's copies: beam k's height and density
    x ``MODEL_FORM_BEAMS[k % 2]`` (so that one scale of E or of the density cannot absorb them).
    ``refine`` (an integer >= 2, ``model_form_refine``) sets how much finer the discretisation
    parts are: element length and pitch / refine, substeps x refine^2 (``refined_sets``, the
    convergence study's refinement: the slipping joint's step error falls at first order;
    refine 2 is SPEC 2's "same model refined"); None (the default) is the halved form: element
    length and pitch / 2, substeps x 2. Everything else (points, screws, actuator, sensors) is ``cfg``'s."""
    p, itf = cfg.plant, cfg.plant.interface
    sets = [s for part, s in zip(REFINED_PARTS, _refined_sets(cfg, refine)) if part in parts]
    if "damping" in parts:
        sets.append(f"plant.interface.tau_s={itf.tau_s * MODEL_FORM_TAU!r}")
    if "beams" in parts:
        for k, b in enumerate(p.beams):
            f = MODEL_FORM_BEAMS[k % len(MODEL_FORM_BEAMS)]
            sets += [f"plant.beams.{b.name}.height_m={b.height_m * f!r}", f"plant.beams.{b.name}.rho={b.rho * f!r}"]
    return with_sets(cfg, sets)


def _refined_sets(cfg: Config, refine: int | None) -> list[str]:
    """--set assignments of the element length, the contact pitch and the plant substeps (in the
    order of ``REFINED_PARTS``) of ``model_form``'s truth: refined by ``refine`` as
    ``frictionrt.rt.common.config.refined_sets`` does, or (None) halved, halved and doubled (the default form)."""
    p = cfg.plant
    if refine is None:
        return [f"plant.element_length_m={p.element_length_m / 2!r}",
                f"plant.interface.pitch_m={p.interface.pitch_m / 2!r}", f"plant.substeps={2 * p.substeps}"]
    pitch, mesh, substeps = refined_sets(cfg, refine)
    return [mesh, pitch, substeps]


def scatter_sets(rng: np.random.Generator) -> dict[str, float]:
    """One campaign's scatter: relative factor per ``SCATTER`` key, 1 + s z with z ~ N(0, 1) cut at +-2."""
    return {k: 1.0 + s * float(np.clip(rng.standard_normal(), -2.0, 2.0)) for k, s in SCATTER.items()}


def ramp_command(ramp_s: float, dt: float, V_hi: float = V_RAMP_V, hold_s: float = HOLD_S) -> np.ndarray:
    """V_cmd [V] per tick: 2 ms at 0 (the diagnosis' noise estimate), ramp to V_hi over ramp_s,
    hold_s held (the bolt force creeps: c log10(1 + t / 1 ms) of the step), ramp down, hold_s at 0
    (the creep back, below the force at 0 V, unlike the piezo hysteresis' offset above it)."""
    n_r = max(1, int(round(ramp_s / dt)))
    hold = lambda s: np.zeros(int(round(s / dt)))   # noqa: E731
    up = np.linspace(0.0, V_hi, n_r + 1)[1:]
    return np.concatenate([hold(2e-3), up, hold(hold_s) + V_hi, up[::-1] - up[0], hold(hold_s)])


def test_record(cfg: Config, kind: str, duration_s: float, amplitude_n: float | None, description: str) -> dict:
    """The ``test`` metadata record of a rig file (docs/data-format.md)."""
    pts = {p.name: p.x_m for p in cfg.plant.points}
    x_screw = require_adaptive_screw(cfg, "a time-series campaign (impulse and actuator tests)").x_m
    rec = {"kind": kind, "excitation_x_m": repr(pts[cfg.plant.excitation_point]),
           "sensor_positions_m": json.dumps({"a_tip_meas": pts["tip"], "a_frf_meas": pts[cfg.plant.frf_point],
                                             "F_strain": x_screw, "F_cell": x_screw}),
           "law": "none", "duration_s": f"{duration_s:.6g}", "description": description}
    if amplitude_n is not None:
        rec["amplitude_n"] = f"{amplitude_n:.6g}"
    return rec


def write_measurement(path: Path, cfg: Config, columns: dict[str, np.ndarray], test: dict) -> None:
    """One file of the campaign: the ``SIGNALS`` columns, the ``test`` record, no configuration; its
    stamps start at the UTC time it is written (``start_utc``, as a lab's recorder stamps a test)."""
    block = np.column_stack([columns[name] for name, _, _ in SIGNALS])
    with McapBlockWriter(path, SIGNALS, cfg.rt.rate_hz, {"start_utc": utc_now()}) as w:
        w.add_metadata("test", test)
        w.write_block(0, block)


def make_campaign(out_dir: str | os.PathLike, effect: str = "none", strength: float | None = None, seed: int = 0,
                  cfg: Config | None = None, record_s: float = 1.0, levels_n=FN1_LEVELS_N,
                  ramps_s=RAMPS_S, stepsine: bool = False, other_form: tuple[str, ...] = (),
                  refine: int | None = None) -> list[Path]:
    """Write a campaign into the new folder ``out_dir`` (written as a temporary folder beside it,
    then renamed: never half a campaign). ``effect``: a name of rt.discrepancy.effects or "none";
    ``strength`` [the effect's unit] defaults to its moderate strength. Returns the files written.
    ValueError for an unknown or unimplemented effect, a strength out of bounds, or an existing
    non-empty ``out_dir``, or an effect that shows only in step-sine tests without ``stepsine``.
    ``stepsine``: also the step-sine FRF tests of rt.discrepancy.rig.stepsine (CSV + sidecar);
    ``other_form``: the truth of another model form made of these parts (``model_form``; () the nominal's),
    its discretisation parts refined by ``refine`` (``model_form``; None: the default form)."""
    if effect != "none" and get(effect).channel == "stepsine" and not stepsine:
        raise ValueError(f"effect {effect!r} shows only in step-sine tests (the shaker's force ratio); add --stepsine")
    rng = np.random.default_rng(seed)
    true = true_structure(cfg, effect, strength, rng, other_form, refine)
    dt = true.dt_s
    model = build_plant(true)
    with new_folder(out_dir) as tmp:
        names = []
        n = int(round(record_s / dt))
        for j, fn1 in enumerate(levels_n):
            peak = HAMMER_PEAK_N * (1.0 + 0.1 * rng.uniform(-1, 1))
            contact = HAMMER_CONTACT_S * (1.0 + 0.1 * rng.uniform(-1, 1))
            n_pre = int(round(PRETRIGGER_S / dt))
            F = np.concatenate([np.zeros(n_pre), hammer_force(n - n_pre, dt, peak, contact)])
            cols = measure_impulse(model, F, hold_voltage(true, fn1), seed=seed * 1000 + j)
            cols["F_exc"] = F + FORCE_NOISE_N * rng.standard_normal(n)
            name = f"impulse_{j + 1:02d}.mcap"
            _add_noise(cols, rng)
            write_measurement(tmp / name, true, cols, test_record(
                true, "impulse", n * dt, float(np.max(cols["F_exc"])),
                f"hammer impulse at the excitation point, adaptive screw held at about {fn1:g} N by the stack"))
            names.append(name)
        for j, ramp in enumerate(ramps_s):
            V = ramp_command(ramp, dt)
            cols = measure_actuator(true, V, seed=seed * 1000 + 100 + j)
            cols["F_exc"] = FORCE_NOISE_N * rng.standard_normal(len(V))
            _add_noise(cols, rng)
            name = f"actuator_{j + 1:02d}.mcap"
            write_measurement(tmp / name, true, cols, test_record(
                true, "actuator", len(V) * dt, None,
                f"voltage ramps 0 -> {V_RAMP_V:g} -> 0 V over {ramp * 1e3:g} ms each, each end held "
                f"{HOLD_S * 1e3:g} ms, structure at rest"))
            names.append(name)
        if stepsine:
            from frictionrt.rt.discrepancy.rig.stepsine import write_stepsine_tests
            names += write_stepsine_tests(tmp, true, levels_n, seed)
    return [Path(out_dir) / n for n in names]


def true_structure(cfg: Config | None, effect: str, strength: float | None, rng: np.random.Generator,
                   other_form: tuple[str, ...] = (), refine: int | None = None) -> Config:
    """The campaign's true structure: ``cfg`` (default: the defaults) with one draw of the scatter
    from ``rng`` and the effect (a name of rt.discrepancy.effects or "none") at ``strength`` (default: its
    moderate strength); of another model form made of the parts ``other_form`` refined by ``refine``
    (``model_form``), if any."""
    nominal = cfg if cfg is not None else with_sets(Config(), [])
    true = scaled(model_form(nominal, other_form, refine) if other_form else nominal, scatter_sets(rng))
    if effect != "none":
        eff = get(effect)
        true = eff.apply(true, eff.parameter.default if strength is None else strength)
    return true


@contextmanager
def new_folder(out_dir: str | os.PathLike):
    """Yields a temporary folder beside ``out_dir`` to fill; renamed to ``out_dir`` on success,
    removed on an exception (never half a campaign). ValueError if ``out_dir`` exists and is not
    an empty folder."""
    out = Path(out_dir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise ValueError(f"{out}: exists and is not an empty folder; choose a new -o DIR")
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        yield tmp
        tmp.chmod(0o755)
        if out.exists():
            out.rmdir()
        os.replace(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise


def _add_noise(cols: dict, rng: np.random.Generator) -> None:
    """The voltage and current monitors' noise (the other channels have theirs from plant.sensors)."""
    cols["V_a"] = cols["V_a"] + V_NOISE_V * rng.standard_normal(len(cols["V_a"]))
    cols["i"] = cols["i"] + I_NOISE_A * rng.standard_normal(len(cols["i"]))

