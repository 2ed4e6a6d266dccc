"""A random test's level in the harmonic balance (``diagnose --calibrate-on`` on random tests, e.g.
``rig --frf-files --levels .. --excitation random``): the joint's spectral equivalent linearisation under
the test's Gaussian response.

The describing-function harmonic balance (plant.harmonic_frf) holds a sine: at a line of frequency f it
gives the FRF under the force F cos(2 pi f t), the joint's amplitude that of this one frequency. A random
test (sidecar "random", rt.log.frf_files) drives the structure with a force of rms F_rms [N] (a drive
voltage of rms V_rms [V]) spread flat over the band f_lo..f_hi, S_ff = F_rms^2 / (f_hi - f_lo) [N^2/Hz]:
every mode responds at once, and each pair's tangential law sees the sum of their motions, whatever the
line. H1 = S_fa / S_ff is then the FRF of a linear system: every closed pair's Jenkins / Iwan element
replaced by the stiffness K_j(f) = S_{f_j x_j}(f) / S_{x_j x_j}(f) that its force and gap have in common
at f, one complex value per measured mode's band here.

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

2. A first stiffness of pair j, Caughey's equivalent linearisation of a hysteretic element under a
   narrow-band Gaussian response (the gap a cos(theta), theta uniform, the envelope a Rayleigh of parameter
   sigma_j; k minimises E[(f - k x)^2], i.e. the describing function k_eq(a) of plant.describing averaged
   with the weight a^2 p(a) / E[a^2]), ``gaussian_stiffness``:

       k_j = int_0^inf k_eq(a) a^3 / (2 sigma_j^4) e^{-a^2 / (2 sigma_j^2)} da
           = int_0^inf k_eq(sigma_j sqrt(2 u)) u e^{-u} du       (u = a^2 / (2 sigma_j^2))

   complex [N/m] (its imaginary part the equivalent damping, rate-independent as the element's loop). Element
   by element (k_eq is their sum), stuck below its slip onset u_i = (q_i / k_i)^2 / (2 sigma_j^2), where
   k_eq = k_i exactly, and by Gauss-Laguerre in v = u - u_i beyond it (``NODES`` nodes), where k_eq is smooth:

       k_i (1 - (1 + u_i) e^{-u_i}) + e^{-u_i} int_0^inf k_eq,i(sigma_j sqrt(2 (u_i + v))) (u_i + v) e^{-v} dv

3. The lines of a linearised model: (D) of plant.harmonic_frf with k_eq(|g|) -> K_j fixed,
   g_t = (I + H_tt diag(K_j - k_t))^-1 H_tF, i.e. a linear model, solved in its own first-order modes (one
   eigen decomposition for all lines with the same K_j, ``_linearised``).

4. The joint's gap is broad-band, not narrow-band: on the lap joint mode 4 carries most of it, and the slips
   that a high mode's motion makes soften a low mode more than the same rms of its own motion would (with
   the true structure's parameters, 2.'s k_j alone met the rig's mode-2 band best with sigma_j x 1.4 at 13.5 V
   rms and x 2 at 54 V). So ``spectral_stiffness`` simulates each closed pair's gap as a Gaussian process with
   the spectrum S_ff |g_j(f)|^2 of the model linearised by 2. on the band's FFT bins (``N_SAMPLES`` samples at
   ``FS_HZ``, the same white noise for every model: ``SEED``), marches its law (``_march``: every element, slip
   force q_i = qf_i mu f_n at the static normal force, as df) and takes K_j,b = sum_b S_fx / sum_b S_xx over
   the bins nearest to each measured mode b. Each line of 3. uses its nearest mode's K_b. One step: a second
   one from K_b (the spectra of 3.) changed the rig's mode-2 band by < 0.003 dB.

Measured on the rig's lap joint (configs/lap_joint_al.toml, micro_slip hidden, seed 0, five drive-voltage
levels 13.5-54 V rms; docs/discrepancy.md "Random excitation"): with the true structure's parameters the gap
in the softening mode's band at 54 V rms is 0.43 dB (13.5-37.8 V: 0.15-0.33 dB); 2. alone leaves 1.40 dB,
the rms-equivalent sine it replaces (the joint's rms mapped to one sine amplitude per mode band) 2.24 dB,
the stuck model 2.88 dB. Cost: 0.13-0.33 s a test of 18,401 lines (9,200 bins simulated; the march of 8 s
of 17 pairs ~10-20 ms; one eigen decomposition per mode band, ``_linearised``).
What it leaves out: the normal contact stays linear (the pairs' normal gaps are not simulated; the slip
force is the static one), the gaps' processes are Gaussian with the linearised model's spectra, and the
pairs' gaps are simulated independently (each law is local; their correlation does not enter K).
"""
from __future__ import annotations

import math

import numba
import numpy as np
from scipy.integrate import trapezoid
from scipy.special import roots_laguerre

from frictionrt.plant.describing import pair_df, slider_amplitude
from frictionrt.plant.harmonic_frf import HarmonicFRF, HarmonicSystem, harmonic_accelerances, harmonic_system
from frictionrt.plant.model import build_plant
from frictionrt.rt.common.config import Config
from frictionrt.rt.discrepancy.chain import quiet
from frictionrt.rt.discrepancy.diagnose.frf import FRFData
from frictionrt.rt.log.frf_files import FRFTest, from_accelerance

NODES = 64
"""Gauss-Laguerre nodes of each element's slipping part of the Rayleigh average (module docstring, 2.): within
1.3e-5 of k_t of scipy's adaptive quadrature on a Jenkins and a 4-element Iwan element (48 nodes over the whole
envelope, the onset's kink inside, left 2e-3)."""
_V, _WV = roots_laguerre(NODES)
_ONE = np.ones(1)
FS_HZ = 8192.0          # sampling rate of the pairs' simulated gaps [Hz]: 6.8 samples a period at 1200 Hz
N_SAMPLES = 2 ** 16     # 8 s of them: 0.125 Hz bins
SEED = 0                # of the simulated gaps' white noise
_WHITE: dict = {}       # pairs -> its spectrum (``_white``)


class RandomLevel(float):
    """A random test's level, its rms over the band [N, or V for a drive voltage] (the float: the level the
    report names and sorts), with every pair's gap rms from the measured response (module docstring, 1.):
    tangential ``sigma_t_m`` and normal ``sigma_n_m`` [m], (pairs,), 0 at the open ones; the test's band
    ``band_hz`` (f_lo, f_hi) [Hz] and its measured modes ``modes_hz`` [Hz] (the bands of 4.)."""

    def __new__(cls, rms: float, sigma_t_m, sigma_n_m, band_hz, modes_hz):
        obj = super().__new__(cls, rms)
        obj.sigma_t_m, obj.sigma_n_m = np.asarray(sigma_t_m, float), np.asarray(sigma_n_m, float)
        obj.band_hz, obj.modes_hz = tuple(map(float, band_hz)), np.asarray(modes_hz, float)
        return obj

    def __reduce__(self):
        return RandomLevel, (float(self), self.sigma_t_m, self.sigma_n_m, self.band_hz, self.modes_hz)

    def band_of(self, freq_hz: np.ndarray) -> np.ndarray:
        """The index of each line's nearest measured mode (in ln f)."""
        return np.argmin(np.abs(np.log(np.asarray(freq_hz, float)[:, None] / self.modes_hz[None, :])), axis=1)


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
    return RandomLevel(r["rms"], np.mean(np.sqrt(var_t), axis=0), np.mean(np.sqrt(var_n), axis=0), r["band_hz"], f_m)


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
    """The random test's accelerances on the lines freq_hz [Hz] (module docstring, 3. and 4.) as a
    plant.harmonic_frf.HarmonicFRF: H [(m/s^2)/N] of the linearised system, each line with its nearest measured
    mode's stiffnesses (``spectral_stiffness`` at the force scale ``scale`` [N/V], 1 for a force); F_amp
    sqrt(2) level x scale [N] and g_t, g_n that force's gaps as a sine [m]; normal_ratio sqrt(2) sigma_n /
    |g_n0| and slip_amp_m the sliders' amplitude at sqrt(2) sigma_t (the rms-equivalent sine's, from the
    measured rms), the same on every line; every line converged."""
    ic = np.flatnonzero(hs.closed)
    K = spectral_stiffness(hs, level, scale)
    F = math.sqrt(2.0) * float(level) * scale
    f = np.asarray(freq_hz, float)
    p, n, m_s = len(hs.closed), len(f), len(hs.names)
    H = np.empty((m_s, n), complex)
    g1 = np.empty((n, 2 * p), complex)
    near = level.band_of(f)
    for b in np.unique(near):
        m = near == b
        w, XV = _linearised(hs, ic, K[b] - hs.k_t[ic], f[m], np.vstack([hs.X_s, hs.X_g]))
        H[:, m] = (-((2.0 * math.pi * f[m]) ** 2)[:, None] * (w @ XV[:m_s].T)).T
        g1[m] = F * (w @ XV[m_s:].T)
    slip, a_slip = np.zeros(p), np.full(p, np.inf)
    slip[ic] = slider_amplitude(math.sqrt(2.0) * level.sigma_t_m[ic], hs.k_t[ic], hs.q[ic], hs.kf, hs.qf)
    a_slip[ic] = [float(np.min(hs.qf * hs.q[j] / (hs.kf * hs.k_t[j]))) for j in ic]
    a_n = math.sqrt(2.0) * level.sigma_n_m / np.maximum(np.abs(hs.g0[0::2]), 1e-300)
    return HarmonicFRF(F_amp=F, method="df", freq_hz=f, H=dict(zip(hs.names, H)), g_t=g1[:, 1::2], g_n=g1[:, 0::2],
                       normal_ratio=np.tile(a_n, (n, 1)), slip_amp_m=np.tile(slip, (n, 1)),
                       open_fraction=np.tile((~hs.closed).astype(float), (n, 1)), closed=hs.closed.copy(),
                       a_slip_m=a_slip, converged=np.ones(n, bool), iterations=np.zeros(n, np.int64),
                       residual=np.zeros(n), n_solutions=np.ones(n, np.int64))


def _linearised(hs: HarmonicSystem, ic: np.ndarray, dk: np.ndarray, f_hz: np.ndarray,
                X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The model whose closed pairs' tangential stiffness is k_t + dk (pc,) complex [N/m], in its own first-order
    modes: (i w - M) z = Y_b per newton, M = diag(lam) - Y_t diag(dk) X_t (the pairs' force -dk g_t, as (D) of
    plant.harmonic_frf), M = V diag(mu) V^-1. Returns (w, X V): w = (V^-1 Y_b) / (i w - mu) on the lines f_hz [Hz],
    (lines, 2n), and the outputs X (rows <- the stuck model's first-order modes) in M's modes, so that the
    outputs per newton are w @ (X V).T; one eigen decomposition for every line."""
    t = 2 * ic + 1
    mu, V = np.linalg.eig(np.diag(hs.lam) - (hs.Y_g[:, t] * dk) @ hs.X_g[t])
    return np.linalg.solve(V, hs.Y_b) / (2j * math.pi * np.asarray(f_hz, float)[:, None] - mu), X @ V


def spectral_stiffness(hs: HarmonicSystem, level: RandomLevel, scale: float) -> np.ndarray:
    """Every closed pair's stiffness [N/m] in the band of each measured mode of ``level``, (modes, pc) complex
    (module docstring, 4.): the pairs' Gaussian gaps simulated with the spectra of the model linearised by
    ``gaussian_stiffness`` at the measured gap rms, under the force density S_ff = (level x scale)^2 /
    (f_hi - f_lo) [N^2/Hz] (``scale`` [N/V], 1 for a force), their laws marched, K = sum_b S_fx / sum_b S_xx."""
    ic = np.flatnonzero(hs.closed)
    lo, hi = level.band_hz
    ff = np.fft.rfftfreq(N_SAMPLES, 1.0 / FS_HZ)
    on = np.flatnonzero((ff >= lo) & (ff <= hi))
    near = level.band_of(ff[on])
    K0 = gaussian_stiffness(level.sigma_t_m[ic], hs.k_t[ic], hs.q[ic], hs.kf, hs.qf)
    w, XV = _linearised(hs, ic, K0 - hs.k_t[ic], ff[on], hs.X_g[2 * ic + 1])
    G = np.zeros((len(ic), len(ff)))
    G[:, on] = np.abs(w @ XV.T).T
    x = np.fft.irfft(_white(len(ic)) * (math.sqrt((float(level) * scale) ** 2 / (hi - lo) * FS_HZ / 2.0) * G),
                     n=N_SAMPLES, axis=1)
    f_t = np.empty_like(x)
    _march(x, hs.kf[None, :] * hs.k_t[ic][:, None], hs.qf[None, :] * hs.q[ic][:, None], f_t)
    X, Fx = np.fft.rfft(x, axis=1)[:, on], np.fft.rfft(f_t, axis=1)[:, on]
    return np.array([np.sum((Fx * X.conj())[:, near == b], axis=1) / np.sum(np.abs(X[:, near == b]) ** 2, axis=1)
                     for b in range(len(level.modes_hz))])


def _white(pairs: int) -> np.ndarray:
    """The spectrum (pairs, N_SAMPLES / 2 + 1) of unit white Gaussian noise from ``SEED``: the same draw for every
    model, so that a fit sees a smooth function of its parameters (common random numbers)."""
    if pairs not in _WHITE:
        _WHITE[pairs] = np.fft.rfft(np.random.default_rng(SEED).standard_normal((pairs, N_SAMPLES)), axis=1)
    return _WHITE[pairs]


@numba.njit(cache=True, nogil=True)
def _march(x, k, q, f):
    """The tangential force f[p, t] [N] of pair p's elements (spring k[p, i] [N/m] in series with a slider of slip
    force q[p, i] [N], as plant.describing's Jenkins element) under its gap x[p, t] [m], every slider starting
    at x[p, 0] unstressed."""
    for p in range(x.shape[0]):
        w = np.full(k.shape[1], x[p, 0])
        for t in range(x.shape[1]):
            s = 0.0
            for i in range(k.shape[1]):
                fi = k[p, i] * (x[p, t] - w[i])
                if fi > q[p, i]:
                    w[i] = x[p, t] - q[p, i] / k[p, i]
                    fi = q[p, i]
                elif fi < -q[p, i]:
                    w[i] = x[p, t] + q[p, i] / k[p, i]
                    fi = -q[p, i]
                s += fi
            f[p, t] = s
