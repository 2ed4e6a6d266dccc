"""Seeded Gaussian noise for the run-time kernels: xoshiro256** uniforms, Box-Muller normals.

The generator's whole state is four uint64 words in a preallocated array that the caller owns
and passes to the kernels, which advance it in place. It does not use numba's (global,
per-thread) NumPy RNG, so a run is reproducible bit for bit from its seed alone, whatever else
in the process draws random numbers, and the sequence does not depend on a tick counter:
it depends only on the seed and on how many numbers were drawn before.

    seeding    s = splitmix64(seed) x 4                       (Vigna; never all zero)
    uniform    xoshiro256** (Blackman & Vigna 2018, period 2^256 - 1):
               out = rotl(s1 * 5, 7) * 9;  t = s1 << 17;
               s2 ^= s0; s3 ^= s1; s1 ^= s2; s0 ^= s3; s2 ^= t; s3 = rotl(s3, 45)
               U = (out >> 11) 2^-53                          in [0, 1), 53 random bits
    normal     Box-Muller: U1, U2 uniform, rho = sqrt(-2 ln(1 - U1))  (1 - U1 in (0, 1]),
               (rho cos 2 pi U2, rho sin 2 pi U2): two independent N(0, 1) per two uniforms

Reference: D. Blackman, S. Vigna, "Scrambled linear pseudorandom number generators", ACM TOMS
47 (2021); https://prng.di.unimi.it/xoshiro256starstar.c and splitmix64.c.
"""
from __future__ import annotations

import math

import numba
import numpy as np

RNG_WORDS = 4
_MASK = (1 << 64) - 1
_GOLDEN = 0x9E3779B97F4A7C15

# uint64 constants (numba would otherwise promote mixed uint64/int arithmetic to float64)
_U5 = np.uint64(5)
_U9 = np.uint64(9)
_U7 = np.uint64(7)
_U57 = np.uint64(57)
_U17 = np.uint64(17)
_U45 = np.uint64(45)
_U19 = np.uint64(19)
_U11 = np.uint64(11)
_TWO_M53 = 2.0 ** -53
_TWO_PI = 2.0 * math.pi


def splitmix64(seed: int, n: int) -> list[int]:
    """The first n outputs of splitmix64 started at `seed` (design time, Python integers)."""
    z_state = seed & _MASK
    out = []
    for _ in range(n):
        z_state = (z_state + _GOLDEN) & _MASK
        z = z_state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & _MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & _MASK
        out.append(z ^ (z >> 31))
    return out


def new_rng(seed: int) -> np.ndarray:
    """A fresh generator state (4,) uint64 for a non-negative integer seed (e.g. cfg.rt.seed).

    The four words are splitmix64(seed), as the xoshiro authors recommend; they are never all
    zero (splitmix64 is a bijection of each 64-bit counter value)."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed = {seed!r}: expected a non-negative integer")
    return np.array(splitmix64(int(seed), RNG_WORDS), dtype=np.uint64)


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _next_u64(s):
    """Next xoshiro256** output (uint64); advances the state s (4,) uint64 in place. RT-safe."""
    s0, s1, s2, s3 = s[0], s[1], s[2], s[3]
    x = s1 * _U5
    out = ((x << _U7) | (x >> _U57)) * _U9
    t = s1 << _U17
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = (s3 << _U45) | (s3 >> _U19)
    s[0] = s0
    s[1] = s1
    s[2] = s2
    s[3] = s3
    return out


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _uniform(s):
    """Uniform double in [0, 1) from the top 53 bits of the next output. RT-safe."""
    return float(_next_u64(s) >> _U11) * _TWO_M53


@numba.njit(cache=True, nogil=True, _nrt=False, error_model="numpy")
def _normal_pair(s):
    """Two independent standard normal numbers (Box-Muller) from two uniforms. RT-safe."""
    u1 = 1.0 - _uniform(s)  # (0, 1]: the log is finite
    u2 = _uniform(s)
    rho = math.sqrt(-2.0 * math.log(u1))
    th = _TWO_PI * u2
    return rho * math.cos(th), rho * math.sin(th)


@numba.njit(cache=True, nogil=True, _nrt=False)
def _fill_normal(s, out):
    """Fill out (n,) with standard normal numbers, pairs in order (z0, z1, z0, z1, ...); an odd
    last entry uses the pair's first number. RT-safe."""
    n = out.shape[0]
    for i in range(0, n - 1, 2):
        a, b = _normal_pair(s)
        out[i] = a
        out[i + 1] = b
    if n % 2 == 1:
        a, _ = _normal_pair(s)
        out[n - 1] = a


@numba.njit(cache=True, nogil=True, _nrt=False)
def _fill_u64(s, out):
    """Fill out (n,) uint64 with raw xoshiro256** outputs. RT-safe."""
    for i in range(out.shape[0]):
        out[i] = _next_u64(s)


def normals(rng: np.ndarray, n: int) -> np.ndarray:
    """n standard normal numbers from the generator state `rng` (advanced), design-time helper."""
    _check(rng)
    out = np.empty(int(n))
    _fill_normal(rng, out)
    return out


def _check(rng: np.ndarray) -> None:
    if not (isinstance(rng, np.ndarray) and rng.dtype == np.uint64 and rng.shape == (RNG_WORDS,)
            and rng.flags.c_contiguous and rng.flags.writeable):
        raise ValueError("rng must be a writeable contiguous uint64 array of shape (4,) from rt.common.noise.new_rng")
    if not rng.any():
        raise ValueError("rng state is all zero (xoshiro256** would output zeros forever); use new_rng(seed)")
