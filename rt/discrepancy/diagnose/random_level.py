"""A random test's level in the harmonic balance (issue 35, ``diagnose --calibrate-on`` on random tests, e.g.
``rig --frf-files --levels .. --excitation random``): the joint's equivalent linearisation under a Gaussian
response.

The describing-function harmonic balance (plant.harmonic_frf) holds a sine: at a line of frequency f it
gives the FRF under the force F cos(2 pi f t), the joint's amplitude that of this one frequency. A random
test (sidecar "random", rt.log.frf_files) drives the structure with a force of rms F_rms [N] (a drive
voltage of rms V_rms [V]) spread flat over the band f_lo..f_hi, S_ff = F_rms^2 / (f_hi - f_lo) [N^2/Hz]:
every mode responds at once, and each pair's tangential law sees the sum of their motions, a Gaussian gap
of rms sigma_j whatever the line. So a random test's FRF is that of a linear system: every closed pair's
Jenkins / Iwan element replaced by its equivalent linearisation under that Gaussian gap.

1. The pairs' gap rms from the measured response (c, b the bands of the measured modes: the test's lines
   within +-``half_width`` of its mode and nearer to it than to another, as
   rt.discrepancy.diagnose.levels.mode_bands), per sensor:

       sigma_c^2   = S_ff int_c |H1(f)|^2 df                     the response's variance in band c (measured)
       r_cj        = |g_j(f_c)| / |H(f_c)|                      pair j's gap per response at c's peak f_c (the stuck
                                                                nominal model, ``pair_ratios``; tangential and normal)
       sigma_j^2   = sum_c r_cj^2 sigma_c^2                     pair j's gap variance, every band's motion [m^2]

   sigma_j is the mean over the sensors. The response's part (sigma_c) is measured, so it holds the joint's
   damping at that level; the model gives only the pairs' share of each mode (its shapes), from the nominal
   structure once per test.

2. The equivalent stiffness of pair j (Caughey's equivalent linearisation of a hysteretic element under a
   narrow-band Gaussian response: the gap a cos(theta) with theta uniform and the envelope a Rayleigh of
   parameter sigma_j; k minimises E[(f - k x)^2], i.e. the describing function k_eq(a) of plant.describing
   averaged with the weight a^2 p(a) / E[a^2]):

       k_j = int_0^inf k_eq(a) a^3 / (2 sigma_j^4) e^{-a^2 / (2 sigma_j^2)} da
           = int_0^inf k_eq(sigma_j sqrt(2 u)) u e^{-u} du       (u = a^2 / (2 sigma_j^2))

   complex [N/m] (its imaginary part the equivalent damping, rate-independent as the element's loop). Element
   by element (k_eq is their sum), stuck below its slip onset u_i = (q_i / k_i)^2 / (2 sigma_j^2), where
   k_eq = k_i exactly, and by Gauss-Laguerre in v = u - u_i beyond it (``NODES`` nodes), where k_eq is smooth:

       k_i (1 - (1 + u_i) e^{-u_i}) + e^{-u_i} int_0^inf k_eq,i(sigma_j sqrt(2 (u_i + v))) (u_i + v) e^{-v} dv

3. Every line of the test is the linear FRF with k_t replaced by k_j at the closed pairs, (D) of
   plant.harmonic_frf with k_eq(|g|) -> k_j fixed: g_t = (I + H_tt diag(k_j - k_t))^-1 H_tF, one solve a line.

Measured on the rig's lap joint (configs/lap_joint_al.toml, micro_slip hidden, seed 0, five drive-voltage
levels 13.5-54 V rms; docs/discrepancy.md "Random excitation"): with the true structure's parameters the gap
in the softening mode's band at 54 V rms is 1.40 dB by this linearisation, 2.24 dB by the rms-equivalent sine
it replaces (the joint's rms mapped to one sine amplitude per mode band) and 2.88 dB stuck. What it leaves
out: the joint's gap is broad-band (on the lap joint mode 4 carries most of it), not narrow-band with a
Rayleigh envelope, and the slips that a high mode's motion makes soften a low mode more than the same rms of
its own motion would: the truth's bands are met best with sigma_j x 1.4 at 13.5 V and x 2 at 54 V.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.integrate import trapezoid
from scipy.special import roots_laguerre
from threadpoolctl import threadpool_limits

from plant.describing import pair_df, slider_amplitude
from plant.harmonic_frf import HarmonicFRF, HarmonicSystem, df_matrices, harmonic_accelerances, harmonic_system
from plant.model import build_plant
from rt.common.config import Config
from rt.discrepancy.chain import quiet
from rt.discrepancy.diagnose.frf import FRFData
from rt.log.frf_files import FRFTest, from_accelerance

NODES = 64
"""Gauss-Laguerre nodes of each element's slipping part of the Rayleigh average (module docstring, 2.): within
1.3e-5 of k_t of scipy's adaptive quadrature on a Jenkins and a 4-element Iwan element (48 nodes over the whole
envelope, the onset's kink inside, left 2e-3)."""
_V, _WV = roots_laguerre(NODES)
_ONE = np.ones(1)


class RandomLevel(float):
    """A random test's level, its rms over the band [N, or V for a drive voltage] (the float: the level the
    report names and sorts), with every pair's gap rms from the measured response (module docstring, 1.):
    tangential ``sigma_t_m`` and normal ``sigma_n_m`` [m], (pairs,), 0 at the open ones."""

    def __new__(cls, rms: float, sigma_t_m, sigma_n_m):
        obj = super().__new__(cls, rms)
        obj.sigma_t_m, obj.sigma_n_m = np.asarray(sigma_t_m, float), np.asarray(sigma_n_m, float)
        return obj

    def __reduce__(self):
        return RandomLevel, (float(self), self.sigma_t_m, self.sigma_n_m)


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
    """The level of the random test ``test`` (its prepared data ``d``: the measured modes) with every pair's gap
    rms from the bands of +-``half_width`` (relative) around the measured modes (module docstring, 1.), the
    pairs' ratios from the stuck ``nominal`` model (it holds the sensors' points) at the test's F_N1.
    ValueError if the test has no measured mode or a mode's band fewer than two lines."""
    r = test.meta["random"]
    f_m = d.modes_hz
    if not len(f_m):
        raise ValueError(f"{test.name}: no mode measured in the random test, so no band to take the joint's motion "
                         "from (docs/discrepancy.md, \"Random excitation\")")
    S = r["rms"] ** 2 / (r["band_hz"][1] - r["band_hz"][0])
    near = np.argmin(np.abs(np.log(d.freq[:, None] / f_m[None, :])), axis=1)
    hs = harmonic_system(build_plant(quiet(nominal)), dict(d.points), F_N1=d.F_N1)
    var_t, var_n = (np.zeros((len(d.H), len(hs.closed))) for _ in range(2))
    for j, fm in enumerate(f_m):
        m = (near == j) & (np.abs(d.freq / fm - 1.0) <= half_width)
        if m.sum() < 2:
            raise ValueError(f"{test.name}: the band of the mode at {fm:g} Hz has {m.sum()} line(s); the response's "
                             "rms in it needs two or more")
        for k, s in enumerate(d.H):
            h = np.abs(d.H[s][m])
            r_t, r_n = pair_ratios(hs, s, float(d.freq[m][np.argmax(h)]), d.quantity)
            var = S * trapezoid(h ** 2, d.freq[m])
            var_t[k] += r_t ** 2 * var
            var_n[k] += r_n ** 2 * var
    return RandomLevel(r["rms"], np.mean(np.sqrt(var_t), axis=0), np.mean(np.sqrt(var_n), axis=0))


def pair_ratios(hs: HarmonicSystem, sensor: str, f_hz: float, quantity: str) -> tuple[np.ndarray, np.ndarray]:
    """(r_t, r_n), (pairs,) each: |g_t,j(f)| / |H_s(f)| and |g_n,j(f)| / |H_s(f)| of the stuck model ``hs`` under
    a unit force at f [Hz], every pair's tangential and normal gap [m] over the sensor's response
    (``quantity``) [m/s^2, m/s or m]; 0 at the open pairs."""
    w = 2.0 * math.pi * f_hz
    modal = hs.Y_b / (1j * w - hs.lam)
    h_s = from_accelerance(np.array([-w * w * (hs.X_s[hs.names.index(sensor)] @ modal)]), np.array([f_hz]), quantity)
    g = np.abs(hs.X_g @ modal) * hs.closed.repeat(2) / abs(h_s[0])
    return g[1::2], g[0::2]


def gaussian_stiffness(sigma_m, k_t, q, kf: np.ndarray, qf: np.ndarray) -> np.ndarray:
    """Equivalent complex stiffness [N/m] of pairs' tangential laws (plant.describing.pair_df: k_t [N/m], slip force
    q [N], the elements' fractions kf, qf) under a narrow-band Gaussian gap of rms sigma_m [m] (module docstring,
    2.); sigma_m = 0: k_t. sigma_m, k_t, q: (pairs,)."""
    sigma_m, k_t, q = (np.asarray(v, float)[:, None] for v in (sigma_m, k_t, q))
    k, s = kf * k_t, qf * q                                    # (pairs, elements): each element's Jenkins k_i, q_i
    with np.errstate(divide="ignore"):
        u_i = np.minimum((s / k) ** 2 / (2.0 * sigma_m ** 2), 1e200)   # its slip onset in u (sigma 0: never)
    u = u_i[..., None] + _V
    keq, _ = pair_df(sigma_m[..., None] * np.sqrt(2.0 * u), k[..., None], s[..., None], _ONE, _ONE)
    slipping = np.exp(-u_i) * np.sum(_WV * u * keq, axis=-1)
    return np.sum(k * (-np.expm1(-u_i) - u_i * np.exp(-u_i)) + slipping, axis=-1)


def level_accelerances(hs: HarmonicSystem, level: float, scale: float, freq_hz: np.ndarray, **kw) -> HarmonicFRF:
    """The harmonic balance's accelerances [(m/s^2)/N] at ``level`` on the lines ``freq_hz`` [Hz]: a sine's
    level (its amplitude) times ``scale`` (the force scale [N/V] of a drive-voltage test, else 1) by
    plant.harmonic_frf.harmonic_accelerances (``kw``); a RandomLevel's by ``random_accelerances``."""
    if isinstance(level, RandomLevel):
        return random_accelerances(hs, level, scale, freq_hz)
    return harmonic_accelerances(hs, level * scale, freq_hz, **kw)


def random_accelerances(hs: HarmonicSystem, level: RandomLevel, scale: float, freq_hz: np.ndarray) -> HarmonicFRF:
    """The random test's accelerances on the lines freq_hz [Hz] (module docstring, 3.) as a
    plant.harmonic_frf.HarmonicFRF: H [(m/s^2)/N] of the linearised system; F_amp sqrt(2) level x scale [N] and
    g_t, g_n that force's gaps as a sine [m]; normal_ratio sqrt(2) sigma_n / |g_n0| and slip_amp_m the sliders'
    amplitude at sqrt(2) sigma_t (the rms-equivalent sine's, from the measured rms), the same on every line;
    every line converged in one solve."""
    ic = np.flatnonzero(hs.closed)
    dk = gaussian_stiffness(level.sigma_t_m[ic], hs.k_t[ic], hs.q[ic], hs.kf, hs.qf) - hs.k_t[ic]
    F = math.sqrt(2.0) * float(level) * scale
    f = np.asarray(freq_hz, float)
    w = 2.0 * math.pi * f
    D = 1.0 / (1j * w[:, None] - hs.lam[None, :])
    with threadpool_limits(1):
        Htt, u = df_matrices(hs, ic, D, F)
        g = np.linalg.solve(np.eye(len(ic))[None] + Htt * dk[None, None, :], u[..., None])[..., 0]
    lam_t = np.zeros((len(f), hs.X_g.shape[0]), complex)
    lam_t[:, 2 * ic + 1] = -dk[None, :] * g              # lambda_t = -(k_j - k_t) g_t, as plant.harmonic_frf's df
    modal = D * (hs.Y_b * F + lam_t @ hs.Y_g.T)
    g1 = modal @ hs.X_g.T
    p, n = len(hs.closed), len(f)
    slip, a_slip = np.zeros(p), np.full(p, np.inf)
    slip[ic] = slider_amplitude(math.sqrt(2.0) * level.sigma_t_m[ic], hs.k_t[ic], hs.q[ic], hs.kf, hs.qf)
    a_slip[ic] = [float(np.min(hs.qf * hs.q[j] / (hs.kf * hs.k_t[j]))) for j in ic]
    a_n = math.sqrt(2.0) * level.sigma_n_m / np.maximum(np.abs(hs.g0[0::2]), 1e-300)
    return HarmonicFRF(F_amp=F, method="df", freq_hz=f, H=dict(zip(hs.names, -(w ** 2) * (modal @ hs.X_s.T).T / F)),
                       g_t=g1[:, 1::2], g_n=g1[:, 0::2], normal_ratio=np.tile(a_n, (n, 1)),
                       slip_amp_m=np.tile(slip, (n, 1)), open_fraction=np.tile((~hs.closed).astype(float), (n, 1)),
                       closed=hs.closed.copy(), a_slip_m=a_slip, converged=np.ones(n, bool),
                       iterations=np.zeros(n, np.int64), residual=np.zeros(n), n_solutions=np.ones(n, np.int64))
