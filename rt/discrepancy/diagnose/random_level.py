"""A random test's level as the harmonic balance's sine amplitude (issue 35, ``diagnose --calibrate-on`` on
random tests, e.g. ``rig --frf-files --levels .. --excitation random``).

The describing-function harmonic balance (plant.harmonic_frf) holds a sine: at a line of frequency f it
gives the FRF under the force F cos(2 pi f t), the joint's amplitude that of this one frequency. A random
test (sidecar "random", rt.log.frf_files) drives the structure with a force of rms F_rms [N] (a drive
voltage of rms V_rms [V]) spread flat over the band f_lo..f_hi, S_ff = F_rms^2 / (f_hi - f_lo) [N^2/Hz]:
every mode responds at once, and the joint slips under the sum of their motions. Mapping (an
rms-equivalent sine per mode band): with c, b the bands of the measured modes (a band: the test's lines
within +-``half_width`` of its mode and nearer to it than to another, as
rt.discrepancy.diagnose.levels.mode_bands), per sensor

    sigma_c^2 = S_ff int_c |H1(f)|^2 df                         the response's variance in band c (measured)
    r_c       = |g_t(f_c)| / |H(f_c)|                           the joint's motion per response at c's peak f_c
                                                               (stuck nominal model; |g_t| the norm of the
                                                               closed pairs' tangential gaps, ``joint_ratio``)
    sigma_g^2 = sum_c r_c^2 sigma_c^2                           the joint's variance, every band's motion
    F_b       = sqrt(2) sigma_g / (r_b max_b |H1|)              the sine amplitude at band b [N, or V]

i.e. the sine at b's peak under which the joint moves with the amplitude sqrt(2) sigma_g of a sine of the
random joint motion's rms (its response r_b max_b |H1| F_b). F_b is the mean over the sensors. With one
mode at the joint, F_b = F_rms sqrt(2 B_b / (f_hi - f_lo)), B_b = int_b |H1|^2 df / max_b |H1|^2 the
mode's noise bandwidth (pi zeta f_b): sqrt(2) times the force's rms within it. The response's part
(sigma_c, max |H1|) is measured, so it holds the joint's damping at that level; the model gives only the
joint's share of each mode (its shapes), from the nominal structure once per test. Every line of the
test, in a band or not, is solved at the F_b of its nearest measured mode (in ln f), in the fit (the
modes' bands) and in the prediction (all lines) alike: the mapping is the test's, not the fit's.

What it leaves out (measured on the rig's lap joint with micro_slip, docs/discrepancy.md "Random
excitation"): a Gaussian response's amplitude is not constant (a Rayleigh envelope about sqrt(2)
sigma_g), and a sine's describing function is not the equivalent linearisation of a Gaussian response:
at the rig's 20 N rms the mode's measured damping is that of the true model's harmonic balance at about
the mapped F_b, its frequency shift that of 3-4x F_b. A sine off the peak also gives the joint less
amplitude than the random response has there.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.integrate import trapezoid

from plant.harmonic_frf import HarmonicFRF, HarmonicSystem, harmonic_accelerances, harmonic_system
from plant.model import build_plant
from rt.common.config import Config
from rt.discrepancy.chain import quiet
from rt.discrepancy.diagnose.frf import FRFData
from rt.log.frf_files import FRFTest, from_accelerance


class RandomLevel(float):
    """A random test's level, its rms over the band [N, or V for a drive voltage] (the float: the level the
    report names and sorts), with the rms-equivalent sine amplitude ``sine_amps`` (module docstring, F_b in
    the level's unit) of each measured mode ``modes_hz`` [Hz]."""

    def __new__(cls, rms: float, modes_hz, sine_amps):
        obj = super().__new__(cls, rms)
        obj.modes_hz, obj.sine_amps = np.asarray(modes_hz, float), np.asarray(sine_amps, float)
        return obj

    def __reduce__(self):
        return RandomLevel, (float(self), self.modes_hz, self.sine_amps)

    def amplitudes(self, freq_hz: np.ndarray) -> np.ndarray:
        """The sine amplitude of each line [N, or V]: its nearest mode's (in ln f)."""
        near = np.argmin(np.abs(np.log(np.asarray(freq_hz, float)[:, None] / self.modes_hz[None, :])), axis=1)
        return self.sine_amps[near]


def is_random(test: FRFTest) -> bool:
    """The test's sidecar says random excitation."""
    return test.meta.get("random") is not None


def random_levels(tests: list[FRFTest], data: list[FRFData], levels: list[float], half_width: float,
                  nominal: Config) -> list[float]:
    """``levels`` (rt.discrepancy.diagnose.levels.level_of) with each random test's a ``random_level``; ValueError
    if the tests mix random and sine excitation (an rms and an amplitude are not one scale)."""
    if len({is_random(t) for t in tests}) > 1:
        raise ValueError("the tests mix random and sine excitation (sidecar random in some only); --calibrate-on "
                         "compares levels of one kind")
    return [random_level(t, d, half_width, nominal) if is_random(t) else a for t, d, a in zip(tests, data, levels)]


def random_level(test: FRFTest, d: FRFData, half_width: float, nominal: Config) -> RandomLevel:
    """The level of the random test ``test`` (its prepared data ``d``: the measured modes) with the sine
    amplitude of each mode's band of +-``half_width`` (relative) (module docstring), the joint ratios r_c
    from the stuck ``nominal`` model (it holds the sensors' points) at the test's F_N1. ValueError if the
    test has no measured mode or a mode's band fewer than two lines."""
    r = test.meta["random"]
    f_m = d.modes_hz
    if not len(f_m):
        raise ValueError(f"{test.name}: no mode measured in the random test, so no band to set the harmonic "
                         "balance's amplitude from (docs/discrepancy.md, \"Random excitation\")")
    S = r["rms"] ** 2 / (r["band_hz"][1] - r["band_hz"][0])
    near = np.argmin(np.abs(np.log(d.freq[:, None] / f_m[None, :])), axis=1)
    names = list(d.H)
    var, peak, f_peak = (np.empty((len(f_m), len(names))) for _ in range(3))
    for j, fm in enumerate(f_m):
        m = (near == j) & (np.abs(d.freq / fm - 1.0) <= half_width)
        if m.sum() < 2:
            raise ValueError(f"{test.name}: the band of the mode at {fm:g} Hz has {m.sum()} line(s); the response's "
                             "rms in it needs two or more")
        for k, s in enumerate(names):
            h = np.abs(d.H[s][m])
            var[j, k], peak[j, k], f_peak[j, k] = S * trapezoid(h ** 2, d.freq[m]), h.max(), d.freq[m][np.argmax(h)]
    hs = harmonic_system(build_plant(quiet(nominal)), dict(d.points), F_N1=d.F_N1)
    ratio = np.array([[joint_ratio(hs, s, f, d.quantity) for s, f in zip(names, row)] for row in f_peak])
    sigma_g = np.sqrt(np.sum(var * ratio ** 2, axis=0))
    return RandomLevel(r["rms"], f_m, np.mean(math.sqrt(2.0) * sigma_g[None, :] / (ratio * peak), axis=1))


def joint_ratio(hs: HarmonicSystem, sensor: str, f_hz: float, quantity: str) -> float:
    """r = |g_t(f)| / |H_s(f)| of the stuck model ``hs`` under a unit force at f [Hz]: the norm of the closed
    pairs' tangential gaps [m] over the sensor's response (``quantity``) [m/s^2, m/s or m]."""
    ic = np.flatnonzero(hs.closed)
    w = 2.0 * math.pi * f_hz
    modal = hs.Y_b / (1j * w - hs.lam)
    h_s = from_accelerance(np.array([-w * w * (hs.X_s[hs.names.index(sensor)] @ modal)]), np.array([f_hz]), quantity)
    return float(np.linalg.norm(hs.X_g[1::2][ic] @ modal) / abs(h_s[0]))


def sine_accelerances(hs: HarmonicSystem, level: float, scale: float, freq_hz: np.ndarray, **kw) -> HarmonicFRF:
    """plant.harmonic_frf.harmonic_accelerances at the sine amplitude of ``level`` times ``scale`` (the force
    scale [N/V] of a drive-voltage test, else 1): a sine's level is its amplitude; a RandomLevel's lines are
    solved band by band at their F_b (``RandomLevel.amplitudes``), each band from its lowest line, and
    joined in the order of ``freq_hz`` (F_amp: the largest F_b [N])."""
    if not isinstance(level, RandomLevel):
        return harmonic_accelerances(hs, level * scale, freq_hz, **kw)
    a = level.amplitudes(freq_hz) * scale
    parts = [(np.flatnonzero(a == v), v) for v in np.unique(a)]
    res = [harmonic_accelerances(hs, v, freq_hz[i], **kw) for i, v in parts]
    order = np.argsort(np.concatenate([i for i, _ in parts]))
    joined = {f.name: np.concatenate([getattr(r, f.name) for r in res])[order]
              for f in dataclasses.fields(HarmonicFRF)
              if f.name not in ("F_amp", "method", "H", "closed", "a_slip_m")}
    H = {s: np.concatenate([r.H[s] for r in res])[order] for s in res[0].H}
    return dataclasses.replace(res[0], F_amp=float(a.max()), H=H, **joined)
