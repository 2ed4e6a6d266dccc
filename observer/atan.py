"""arctan with the same bits on every machine: fdlibm's s_atan.c, compiled by numba.

The observer's friction term f_r = mu F_N (2/pi) arctan(alpha v) is the only libm call on the
controller's replay path (docs/determinism.md). ``math.atan`` in a kernel calls the C library's
atan, and glibc picks an FMA-compiled variant of it on CPUs that have FMA: the same argument
can give a result one unit in the last place apart on two machines (measured here with
``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA``: a replay 8.9e-16 off at tick 789). This is the
Sun/FreeBSD algorithm (error < 1 ulp) in plain IEEE double arithmetic without fastmath, so on the
generic x86-64 target (rt/common/codegen.py) it computes the same bits everywhere.

    |x| < 7/16                 atan(x) = x - x (s1 + s2)            (odd polynomial in x^2)
    7/16 .. 11/16 .. 19/16 .. 39/16 .. 2^66
                               atan(x) = atan(c_i) + atan((x - c_i) / (1 + c_i x)),
                               c_i = 1/2, 1, 3/2, inf, atan(c_i) as hi + lo parts
    |x| >= 2^66                +-pi/2;  NaN -> NaN

Reference: fdlibm 5.3 (Sun Microsystems, 1993), e_atan.c / s_atan.c, as in FreeBSD's msun.
"""
from __future__ import annotations

import numba

ATAN_HI = (4.63647609000806093515e-01, 7.85398163397448278999e-01, 9.82793723247329054082e-01,
           1.57079632679489655800e+00)
ATAN_LO = (2.26987774529616870924e-17, 3.06161699786838301793e-17, 1.39033110312309984516e-17,
           6.12323399573676603587e-17)
AT = (3.33333333333329318027e-01, -1.99999999998764832476e-01, 1.42857142725034663711e-01,
      -1.11111104054623557880e-01, 9.09088713343650656196e-02, -7.69187620504482999495e-02,
      6.66107313738753120669e-02, -5.83357013379057348645e-02, 4.97687799461593236017e-02,
      -3.65315727442169155270e-02, 1.62858201153657823623e-02)


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _atan(x):
    """arctan(x) [rad] in (-pi/2, pi/2), error < 1 ulp, the same bits on every x86-64. RT-safe."""
    if x != x:
        return x
    a = abs(x)
    if a >= 7.378697629483820646e19:   # 2^66
        return ATAN_HI[3] + ATAN_LO[3] if x > 0.0 else -ATAN_HI[3] - ATAN_LO[3]
    i = -1
    if a < 0.4375:
        if a < 1.862645149230957e-09:  # 2^-29: atan(x) = x to round-off
            return x
        t = x
    elif a < 0.6875:
        i = 0
        t = (2.0 * a - 1.0) / (2.0 + a)
    elif a < 1.1875:
        i = 1
        t = (a - 1.0) / (a + 1.0)
    elif a < 2.4375:
        i = 2
        t = (a - 1.5) / (1.0 + 1.5 * a)
    else:
        i = 3
        t = -1.0 / a
    z = t * t
    w = z * z
    s1 = z * (AT[0] + w * (AT[2] + w * (AT[4] + w * (AT[6] + w * (AT[8] + w * AT[10])))))
    s2 = w * (AT[1] + w * (AT[3] + w * (AT[5] + w * (AT[7] + w * AT[9]))))
    if i < 0:
        return t - t * (s1 + s2)
    r = ATAN_HI[i] - ((t * (s1 + s2) - ATAN_LO[i]) - t)
    return r if x > 0.0 else -r
