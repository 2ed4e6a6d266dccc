"""Run time: the amplitude-following observer's step at 21 kHz (``frictionrt.observer.amplitude``).

The paper's step (``frictionrt.observer.step``) with the time update's modal blocks interpolated
per mode from that mode's amplitude; per tick k with the a-priori state z_k|k-1 (slots q_1..q_N,
q_1'..q_N'):

    e       = y_k - C_meas z_k|k-1,   z_k|k = z_k|k-1 + M e          (the paper's gain M)
    a_i     = |t phi_i| sqrt(q_i^2 + (q_i' / omega_i)^2)              from z_k|k
    (Ad_i, bd_i) = blocks[i, j] (1 - w) + blocks[i, j + 1] w,          grid[j] <= a_i < grid[j + 1]
    p_i     = blocks[i, j, 6] + w (blocks[i, j + 1, 6] - blocks[i, j, 6])   mode i's participation
    outputs as the paper's with mode i's rows of C_u, C_v times p_i (the paper's where every p_i = 1):
            v_rel_hat = sum_i p_i C_v,i z_i, f_r,k = f_r(v_rel_hat, F_N,k), u_rel_hat = sum_i p_i C_u,i z_i + D_u f_r,k
    v_next solves v = sum_i p_i t phi_i (Ad_i z_i)[1] + beta f_r(v, F_N,k),  beta = sum_i p_i t phi_i bd_i[1] < 0
    z_k+1|k,i = Ad_i z_k|k,i + bd_i f_r(v_next, F_N,k)                 (bd_i carries p_i: the design's)

With the Jenkins joint (k_j > 0; state slot 2N the slider's position s [m], slip limit
q = mu |F_N|) the friction force is the spring's, f = k_j (u_rel - s) clamped to [-q, q], held
over the tick at its end-of-tick value (return mapping, closed form):

    output:  f_k = clamp(k_j (u_lin - s) / (1 - k_j D_u))              u_lin = C_u z_k|k
    update:  u* = C_u (Ad z_k|k),  c = C_u bd + D_u < 0
             f = k_j (u* - s) / (1 - k_j c);  |f| > q: f = sign(f) q, s_next = u* + c f - f / k_j

Inputs, outputs as the paper's step (``OBSERVER_OUTPUTS``); state z_k|k-1 (2N), and s with the
Jenkins joint.
"""
from __future__ import annotations

import math

import numba

from frictionrt.observer.step import _friction, _implicit_v


@numba.njit(cache=True, nogil=True, _nrt=False, inline="always")
def _clamp(f, q):
    return q if f > q else (-q if f < -q else f)


@numba.njit(cache=True, nogil=True, _nrt=False)
def _amplitude_step(k, x, u, p, a, w, x_next, y):
    """One tick of the amplitude-following observer (module docstring). RT-safe, allocation-free.

    k int64 tick (unused); x (2N,) z_k|k-1 (2N + 1 with the Jenkins joint: the slider last); u (2,)
    = (y_meas [m/s], F_N [N]); p ObserverParams (the paper's: M, C_meas, C_u, C_v, D_u, mu, alpha);
    a AmplitudeParams; w (>= 2N,) scratch (the interpolated bd per mode); x_next like x (written;
    must not alias x); y (4,) outputs."""
    M, C_meas, C_u, C_v = p.M, p.C_meas, p.C_u, p.C_v
    grid, blocks, scale, inv_omega = a.grid, a.blocks, a.scale, a.inv_omega
    n = M.shape[0]
    N = n // 2
    G = grid.shape[0]
    F_N = u[1]
    k_j = a.k_j
    jenkins = k_j > 0.0
    e = u[0]
    for i in range(n):
        e -= C_meas[i] * x[i]
    v_hat = 0.0
    u_lin = 0.0
    for i in range(n):
        zi = x[i] + M[i] * e
        x_next[i] = zi
        v_hat += C_v[i] * zi
        u_lin += C_u[i] * zi
    # per mode: the blocks and the participation p_i at its amplitude (the outputs' share of mode i
    # made p_i times; nothing added where p_i = 1), A z into x_next, bd into w
    v_star = 0.0
    beta = 0.0
    u_star = 0.0
    c_u = p.D_u
    for i in range(N):
        q = x_next[i]
        qd = x_next[N + i]
        r = qd * inv_omega[i]
        amp = scale[i] * math.sqrt(q * q + r * r)
        j = 0
        while j < G - 2 and amp >= grid[j + 1]:
            j += 1
        wt = (amp - grid[j]) / (grid[j + 1] - grid[j])
        if wt > 1.0:
            wt = 1.0
        b0 = blocks[i, j]
        b1 = blocks[i, j + 1]
        c0 = 1.0 - wt
        pi = b0[6] + wt * (b1[6] - b0[6])
        dp = pi - 1.0
        v_hat += dp * (C_v[i] * q + C_v[N + i] * qd)
        u_lin += dp * (C_u[i] * q + C_u[N + i] * qd)
        a11 = c0 * b0[0] + wt * b1[0]
        a12 = c0 * b0[1] + wt * b1[1]
        a21 = c0 * b0[2] + wt * b1[2]
        a22 = c0 * b0[3] + wt * b1[3]
        w[i] = c0 * b0[4] + wt * b1[4]
        w[N + i] = c0 * b0[5] + wt * b1[5]
        x_next[i] = a11 * q + a12 * qd
        x_next[N + i] = a21 * q + a22 * qd
        cv = pi * C_v[N + i]
        cu = pi * C_u[i]
        v_star += cv * x_next[N + i]
        beta += cv * w[N + i]
        u_star += cu * x_next[i]
        c_u += cu * w[i]
    q_slip = p.mu * abs(F_N)
    s = 0.0
    if jenkins:
        s = x[n]
        f_k = _clamp(k_j * (u_lin - s) / (1.0 - k_j * p.D_u), q_slip)
    else:
        f_k, _ = _friction(v_hat, F_N, p.mu, p.alpha)
    y[0] = u_lin + p.D_u * f_k
    y[1] = v_hat
    y[2] = e
    y[3] = f_k
    if jenkins:  # return mapping of the spring-slider with the force held over the tick
        f_next = k_j * (u_star - s) / (1.0 - k_j * c_u)
        if f_next > q_slip or f_next < -q_slip:
            f_next = _clamp(f_next, q_slip)
            x_next[n] = u_star + c_u * f_next - f_next / k_j
        else:
            x_next[n] = s
    else:  # time update with the friction at the end-of-tick velocity (the paper's implicit solve)
        v_next = _implicit_v(v_star, beta, F_N, p.mu, p.alpha)
        f_next, _ = _friction(v_next, F_N, p.mu, p.alpha)
    for i in range(n):
        x_next[i] += w[i] * f_next
