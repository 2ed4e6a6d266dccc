"""A random test's level as the harmonic balance's sine amplitude (issue 35, ``diagnose --calibrate-on`` on
random tests, e.g. ``rig --frf-files --levels .. --excitation random``).

The describing-function harmonic balance (plant.harmonic_frf) holds a sine: at a line of frequency f it
gives the FRF under the force F cos(2 pi f t). A random test (sidecar "random", rt.log.frf_files) drives
the structure with a force of rms F_rms [N] (a drive voltage of rms V_rms [V]) spread flat over the band
f_lo..f_hi, S_ff = F_rms^2 / (f_hi - f_lo) [N^2/Hz]; near a mode the response is narrow-band, its
amplitude (the envelope) what the joint sees. Mapping, per measured mode m (its band b: the test's lines
within +-``half_width`` of the mode and nearer to it than to another measured mode, as
rt.discrepancy.diagnose.levels.mode_bands):

    sigma_b^2 = S_ff int_b |H1(f)|^2 df                       the response's variance in the band
    F_b       = sqrt(2) sigma_b / max_b |H1|                  the rms-equivalent sine amplitude [N]
              = F_rms sqrt(2 B_b / (f_hi - f_lo)),   B_b = int_b |H1|^2 df / max_b |H1|^2   [Hz]

i.e. the sine whose response at the band's peak has the amplitude sqrt(2) sigma_b of a sine of the
random response's rms; B_b is the mode's noise bandwidth (pi zeta f_m for one mode of damping ratio
zeta: 3.5 Hz at 374 Hz and 0.3 %), F_b sqrt(2) times the force's rms within it. B_b is the mean over
the test's sensors (the same for an isolated mode), from the measured H1, so it takes the joint's
damping at that level as measured, and it needs no model. Every line of the test, in a band or not,
is solved at the F_b of its nearest measured mode (in ln f), in the fit (the modes' bands) and in the
prediction (all lines) alike: the mapping is the test's, not the fit's.

What it leaves out: the random response's amplitude is not constant (a Rayleigh envelope about
sqrt(2) sigma_b): the equivalent linearisation of a Gaussian response differs from the describing
function at sqrt(2) sigma_b by a factor on the amplitude that, for a joint whose slip grows as a
power of the amplitude (micro-slip), is the same at every level and is taken up by mu in the fit; a
sine off the peak gives the joint less amplitude than the random response has there, so the lines on
a peak's flanks are solved nearer to stuck than they were measured.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.integrate import trapezoid

from plant.harmonic_frf import HarmonicFRF, HarmonicSystem, harmonic_accelerances
from rt.discrepancy.diagnose.frf import FRFData
from rt.log.frf_files import FRFTest


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


def random_level(test: FRFTest, d: FRFData, half_width: float) -> RandomLevel:
    """The level of the random test ``test`` (its prepared data ``d``: the measured modes) with the sine
    amplitude of each mode's band of +-``half_width`` (relative) (module docstring). ValueError if the
    test has no measured mode."""
    r = test.meta["random"]
    f_m = d.modes_hz
    if not len(f_m):
        raise ValueError(f"{test.name}: no mode measured in the random test, so no band to set the harmonic "
                         "balance's amplitude from (docs/discrepancy.md, \"Random excitation\")")
    S = r["rms"] ** 2 / (r["band_hz"][1] - r["band_hz"][0])
    near = np.argmin(np.abs(np.log(d.freq[:, None] / f_m[None, :])), axis=1)
    amps = []
    for j, fm in enumerate(f_m):
        m = (near == j) & (np.abs(d.freq / fm - 1.0) <= half_width)
        if m.sum() < 2:
            raise ValueError(f"{test.name}: the band of the mode at {fm:g} Hz has {m.sum()} line(s); the noise "
                             "bandwidth needs two or more")
        B = [trapezoid(np.abs(h[m]) ** 2, d.freq[m]) / np.max(np.abs(h[m])) ** 2 for h in d.H.values()]
        amps.append(math.sqrt(2.0 * S * np.mean(B)))
    return RandomLevel(r["rms"], f_m, amps)


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
