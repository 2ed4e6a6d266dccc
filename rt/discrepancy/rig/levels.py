"""Multi-level FRF files from the nonlinear plant (``frictionrt rig --frf-files --levels``):
what a lab exports from stepped-sine tests at several excitation levels, where the joint's
micro-slip softens and damps its modes as the level rises.

Per force amplitude F [N] (``--levels``; default ``LEVELS_N``) one stepped-sine up-sweep of the
nonlinear plant (plant.simulate.run: Newmark with the friction contact and the bolts, the adaptive
screw, if the structure has one, held at F_N1 by the stack, chain.stack_force) under the ideal force F cos(w t_k) at the
excitation point, each line from the previous line's final state and force phase. Per line (``settle_line``):
blocks of whole periods (rt.experiments.stepsine.Settle: >= 10 periods and >= 20 ms; ``SETTLE``
gives up after 4 s) until the first harmonic of a_frf is steady (rt.experiments.stepsine.steady,
the geometric-tail test, 1 %); the line's FRF is the mean over the final 3 blocks of

    H_s = X_s e^{i w dt / 2} / F                                                 [(m/s^2)/N]

X_s the Hann-weighted first harmonic of the acceleration a_s at t_{k+1} (the plant's output after
step k), the factor e^{i w dt/2} referring the force held over step k to the middle of the step.
At a level where the contact stays stuck this is the stuck plant's FRF up to the Newmark step's
period error ((w dt)^2 / 12: 0.1 % at 400 Hz; the continuous model of the diagnosis does not have
it, as a real structure's FRF does not).

Lines (``level_lines``): ``LINES_PER_MODE`` over +-``HALF_WIDTH`` around each mode of the stuck
structure at F_N1 inside ``BAND_HZ`` (rt.experiments.stepsine.resonance_grid), plus a coarse grid of
``COARSE_LINES`` log-spaced lines across the band. The same lines at every level, as a lab's test
plan. Noise as rt.discrepancy.rig.frf (``NOISE_REL`` of |H| plus ``NOISE_FLOOR``). Files
``level_NN`` alternately CSV and UFF, kind "frf", ``amplitude_n`` = F; the sidecars are the same for
every hidden effect.

Random excitation (``excitation`` "random"): per level a band-limited Gaussian force of that
rms [N] over ``BAND_HZ`` (a drive voltage of that rms [V] with a force scale) for one record, H1 and its
coherence by Welch's method on the band's 0.0625 Hz lines (rt.discrepancy.rig.random_excitation); no
noise added to H1 (the accelerometers' noise is in the record), the sidecar's "random" names the level
(rms), the band and the estimator, amplitude_n and drive_amplitude_v null.

Beside the levels (``broadband``): one low-level FRF over the whole band, ``broadband.csv``, written as
rt.discrepancy.rig.frf writes FRF files (the true structure's stuck FRF at the held F_N1 on its FREQ_HZ,
4-1600 Hz at 0.25 Hz, with its noise): what a lab measures first, at a level where no pair slips, and what
shows the modes below the level tests' band (the stuck structure's modes 1 and 2 ring for tens of seconds at
0.1 % damping, so their stepped-sine lines do not settle within ``SETTLE``). Sidecar ``broadband`` true,
amplitude_n null (a drive-voltage campaign: per volt, as the levels). Not a simulation of a random test:
at a level where no pair slips the stuck FRF is the structure's; a random test's H1 bias and random error
are not in it.
"""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import NamedTuple

import numpy as np
from threadpoolctl import threadpool_limits

from frictionrt.plant.model import PlantModel, build_plant, preloaded_pairs, stuck_frequencies_hz
from frictionrt.plant.simulate import run
from frictionrt.rt.common.config import Config, adaptive_screw
from frictionrt.rt.discrepancy.chain import hold_voltage, stack_force
from frictionrt.rt.discrepancy.effects import get
from frictionrt.rt.discrepancy.rig.campaign import new_folder, true_structure
from frictionrt.plant.linear_frf import point_accelerances
from frictionrt.rt.discrepancy.rig.frf import FREQ_HZ, NOISE_FLOOR, NOISE_REL, drive_force_ratio, frf_meta, sensor_points
from frictionrt.rt.discrepancy.rig.random_excitation import OVERLAP, random_test, record_s
from frictionrt.rt.experiments.stepsine import Settle, harmonics_of_columns, resonance_grid, steady
from frictionrt.rt.log.frf_files import FRFTest, write_frf_csv, write_frf_uff

LEVELS_N = (0.5, 1.0, 2.0, 5.0, 10.0, 20.0)   # [N] force amplitudes
BAND_HZ = (50.0, 1200.0)                       # [Hz] lines inside this band
HALF_WIDTH = 0.12                              # relative half width of the band around each mode
LINES_PER_MODE = 13                            # 2 % steps: friction-softened peaks are 3-10 % wide
COARSE_LINES = 8                               # log-spaced lines across BAND_HZ
F_N1_N = 100.0                                 # [N] the adaptive screw's held force
EXCITATIONS = ("stepsine", "random")             # how the levels are driven (module docstring)
SETTLE = Settle(max_s=4.0)                     # a line gives up after 4 s of simulated time (lines 2 % off a
                                               # bare-beam mode of 0.1 % damping ring for longer: left out)


class LevelSweep(NamedTuple):
    """One level's stepped-sine sweep."""
    amp_n: float                 # force amplitude [N]
    freq_hz: np.ndarray          # lines [Hz]
    H: dict                      # sensor -> complex (n,) accelerance [(m/s^2)/N]
    settled: np.ndarray          # (n,) bool: the line met the steady test before SETTLE.max_s
    sim_s: float                 # simulated time of the sweep [s]


def level_lines(model: PlantModel, F_N1: float, band_hz=BAND_HZ) -> np.ndarray:
    """The test plan's lines [Hz] (module docstring) for the stuck structure of ``model`` at F_N1 [N].
    ValueError if no mode of the stuck structure lies inside ``band_hz``."""
    f = stuck_frequencies_hz(model, preloaded_pairs(model, F_N1))
    f = f[(f > band_hz[0]) & (f < band_hz[1])]
    if len(f) == 0:
        raise ValueError(f"no mode of the stuck structure lies in {band_hz[0]:g}..{band_hz[1]:g} Hz: "
                         "the level tests need one")
    dense = resonance_grid(f, HALF_WIDTH, LINES_PER_MODE)
    dense = dense[(dense >= band_hz[0]) & (dense <= band_hz[1])]
    coarse = np.geomspace(band_hz[0], band_hz[1], COARSE_LINES)
    coarse = coarse[np.min(np.abs(coarse[:, None] / dense[None, :] - 1.0), axis=1) > 0.01]   # none within 1 %
    return np.sort(np.concatenate([dense, coarse]))


def settle_line(model: PlantModel, x: np.ndarray, phase: float, freq_hz: float, amp_n: float, F_N1: float,
                cols: list[int], settle: Settle = SETTLE) -> tuple[np.ndarray, np.ndarray, float, bool, float]:
    """One line (module docstring) from state x and force phase ``phase`` [rad]: (H per column of
    ``cols`` (m,), final state, final phase, settled, simulated time [s]). The force
    F_k = amp_n cos(phase + w k dt) keeps its phase across lines (a frequency step does not kick
    the lightly damped low modes, which a phase restart would set ringing for seconds)."""
    dt = model.cfg.dt_s
    nb = settle.block_ticks(freq_hz, dt)
    w = 2.0 * math.pi * freq_hz
    blocks, k, ok = [], 0, False
    while k * dt < settle.max_s:
        F = amp_n * np.cos(phase + w * dt * np.arange(nb))
        Y, x, _ = run(model, F, F_N1, x0=x)
        hs = harmonics_of_columns(Y[:, cols], freq_hz, dt, 1, k0=1, window=settle.window)
        blocks.append(np.array([h.X[0] for h in hs]) * np.exp(0.5j * w * dt - 1j * phase) / amp_n)
        phase = math.remainder(phase + w * dt * nb, 2.0 * math.pi)
        k += nb
        ok, _ = steady([b[0] for b in blocks], settle.n_blocks, settle.rel_tol)
        if ok:
            break
    return np.mean(blocks[-settle.n_blocks:], axis=0), x, phase, ok, k * dt


def sensor_columns(model: PlantModel) -> dict[str, int]:
    """{accelerometer: column of its acceleration in the plant's outputs}."""
    io = model.output_index()
    return {s: io[f"a_{p}"] for s, p in sensor_points(model.cfg).items()}


def sweep_level(model: PlantModel, F_N1: float, amp_n: float, lines_hz: np.ndarray) -> LevelSweep:
    """The up-sweep at force amplitude ``amp_n`` [N] over ``lines_hz`` from rest at F_N1 [N]."""
    by_name = sensor_columns(model)
    names, cols = list(by_name), list(by_name.values())
    x, phase = model.initial_state(F_N1), -0.5 * math.pi      # the force starts at 0 from rest
    H = np.empty((len(lines_hz), len(names)), complex)
    settled = np.zeros(len(lines_hz), bool)
    sim_s = 0.0
    for i, f in enumerate(lines_hz):
        H[i], x, phase, settled[i], t = settle_line(model, x, phase, float(f), amp_n, F_N1, cols)
        sim_s += t
    return LevelSweep(amp_n, np.asarray(lines_hz, float), {s: H[:, j] for j, s in enumerate(names)}, settled, sim_s)


def write_broadband(folder: Path, true: Config, model: PlantModel, F_N1: float, rng: np.random.Generator,
                    force_scale_N_per_V: float | None = None) -> str:
    """The low-level FRF over the whole band beside the levels (module docstring) into ``folder``; its name."""
    H = point_accelerances(model, sensor_points(true), F_N1, FREQ_HZ)
    per_volt = force_scale_N_per_V is not None
    if per_volt and true.shaker.on:
        ratio = drive_force_ratio(true, model, F_N1, FREQ_HZ)
        H = {s: h * ratio for s, h in H.items()}
    gain = float(force_scale_N_per_V) if per_volt else 1.0
    for s, h in H.items():
        z, w = rng.standard_normal((2, len(h), 2)) @ np.array([1.0, 1j]) / np.sqrt(2)
        H[s] = gain * (h * (1.0 + NOISE_REL * z) + NOISE_FLOOR * w)
    held = f"adaptive screw held at about {F_N1_N:g} N by the stack" if F_N1 else "no adaptive screw"
    drive = "shaker driven by a voltage, no force transducer" if per_volt else "force"
    meta = frf_meta(true, round(F_N1, 2), f"low-level FRF over the whole band beside the level tests, {drive} at "
                    f"the excitation point (contact stuck), {held}") | {"amplitude_n": None, "broadband": True} | (
        {"excitation": "drive_voltage"} if per_volt else {})
    write_frf_csv(folder / "broadband.csv", FRFTest("broadband", FREQ_HZ, H, None, None, meta))
    return "broadband.csv"


def write_level_tests(folder: Path, true: Config, levels_n, rng: np.random.Generator,
                      progress=None, band_hz=BAND_HZ, force_scale_N_per_V: float | None = None,
                      excitation: str = "stepsine", broadband: bool = False) -> list[str]:
    """Run the level tests on the true structure and write them into ``folder`` (module docstring; stepped
    sines on lines around the modes in ``band_hz`` [Hz], or with ``excitation`` "random" a random force over
    ``band_hz``); returns the data file names. ``progress(msg)`` is told of each level. ``force_scale_N_per_V``
    s: a voltage-driven shaker without force transducer, the levels are drive amplitudes (rms, random) V [V],
    the force s V, the files' FRFs per volt (s H) with the sidecar's excitation drive_voltage and
    drive_amplitude_v V (stepped sine) or random.rms V. ``broadband``: also the low-level FRF over the whole band
    (``write_broadband``), after the levels."""
    with threadpool_limits(1):
        model = build_plant(true)
        F_N1 = stack_force(true, hold_voltage(true, F_N1_N)) if adaptive_screw(true) is not None else 0.0
        lines = level_lines(model, F_N1, band_hz) if excitation == "stepsine" else None
    names = []
    gain = 1.0 if force_scale_N_per_V is None else float(force_scale_N_per_V)
    unit = "N" if force_scale_N_per_V is None else "V"
    held = f"adaptive screw held at about {F_N1_N:g} N by the stack" if F_N1 else "no adaptive screw"
    for j, amp in enumerate(levels_n):
        if excitation == "random":
            if progress:
                progress(f"level {j + 1}/{len(levels_n)}: {amp:g} {unit} rms, a {record_s():g} s record")
            rnd = random_test(model, F_N1, float(amp) * gain, band_hz, sensor_columns(model), rng)
            freq, H, coh = rnd.freq_hz, {s: gain * h for s, h in rnd.H.items()}, rnd.coherence
            drive = (f"force of {amp:g} N rms" if force_scale_N_per_V is None else
                     f"shaker driven by a voltage of {amp:g} V rms, no force transducer")
            how = (f"band-limited random excitation ({band_hz[0]:g}-{band_hz[1]:g} Hz, flat), {drive} at the "
                   f"excitation point, {held}; H1 by Welch's method, {rnd.averages} Hann blocks of {rnd.block_s:g} s, "
                   f"{OVERLAP:.0%} overlap")
            extra = ({"amplitude_n": None} if force_scale_N_per_V is None else
                     {"amplitude_n": None, "excitation": "drive_voltage"}) | {"random": {
                         "rms": float(amp), "band_hz": [float(band_hz[0]), float(band_hz[1])], "block_s": rnd.block_s,
                         "averages": rnd.averages, "overlap": OVERLAP, "window": "hann"}}
        else:
            if progress:
                progress(f"level {j + 1}/{len(levels_n)}: {amp:g} {unit}, {len(lines)} lines")
            sw = sweep_level(model, F_N1, float(amp) * gain, lines)
            H, coh, freq = {}, None, sw.freq_hz[sw.settled]
            for s, h in sw.H.items():
                z, w = rng.standard_normal((2, len(h), 2)) @ np.array([1.0, 1j]) / np.sqrt(2)
                H[s] = gain * (h * (1.0 + NOISE_REL * z) + NOISE_FLOOR * w)[sw.settled]
            drive = (f"force amplitude held at {amp:g} N" if force_scale_N_per_V is None else
                     f"shaker driven by a voltage of {amp:g} V amplitude, no force transducer")
            how = (f"stepped-sine up-sweep, {drive} at the excitation point, {held}; lines that did not settle "
                   f"within {SETTLE.max_s:g} s left out")
            extra = ({"amplitude_n": float(amp)} if force_scale_N_per_V is None else
                     {"amplitude_n": None, "excitation": "drive_voltage", "drive_amplitude_v": float(amp)})
        meta = frf_meta(true, round(F_N1, 2), how) | extra
        name = f"level_{j + 1:02d}" + (".uff" if j % 2 else ".csv")
        (write_frf_uff if j % 2 else write_frf_csv)(folder / name, FRFTest(Path(name).stem, freq, H, None, None,
                                                                           meta, coh))
        names.append(name)
    if broadband:
        names.append(write_broadband(folder, true, model, F_N1, rng, force_scale_N_per_V))
    return names


def make_level_campaign(out_dir: str | os.PathLike, effect: str = "none", strength: float | None = None,
                        seed: int = 0, cfg: Config | None = None, force_levels_n=LEVELS_N,
                        other_form: tuple[str, ...] = (), progress=None, band_hz=BAND_HZ,
                        force_scale_N_per_V: float | None = None, excitation: str = "stepsine",
                        refine: int | None = None, broadband: bool = False) -> list[Path]:
    """Write the level tests (module docstring) into the new folder ``out_dir`` (a temporary folder,
    then renamed), from the true structure of rt.discrepancy.rig.campaign.true_structure (the same scatter draw and
    hidden effect for the seed, ``other_form`` refined by ``refine``; lines around the modes in ``band_hz`` [Hz]; ``force_scale_N_per_V``: the
    levels are drive voltages, as write_level_tests; ``excitation``: "stepsine" or "random", as there; ``broadband``:
    also the low-level FRF over the whole band, as there); returns the
    data files written. ValueError for an effect of the actuator or the shaker (FRF files of the structure do not
    record them), an unknown excitation or a level that is not a positive finite force."""
    if excitation not in EXCITATIONS:
        raise ValueError(f"excitation {excitation!r}: give one of {', '.join(EXCITATIONS)}")
    if effect != "none" and get(effect).channel != "structure":
        raise ValueError(f"effect {effect!r} acts through the actuator or the shaker, which FRF files of the "
                         "structure do not record; write a time-series campaign instead (rig without --frf-files)")
    levels = [float(a) for a in force_levels_n]
    if not levels or not all(math.isfinite(a) and a > 0 for a in levels):
        raise ValueError(f"levels {list(force_levels_n)}: give positive amplitudes (N, or V with a force scale), "
                         "e.g. 0.5,1,2,5")
    rng = np.random.default_rng(seed)
    true = true_structure(cfg, effect, strength, rng, other_form, refine)
    with new_folder(out_dir) as tmp:
        names = write_level_tests(tmp, true, sorted(levels), rng, progress, band_hz, force_scale_N_per_V, excitation,
                                  broadband)
    return [Path(out_dir) / n for n in names]
