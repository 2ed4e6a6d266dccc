/*
 * frictionrt_ctrl.c: one tick of the frictionrt controller (frictionrt_ctrl.h).
 *
 * A line-by-line transcription of the numba kernels the loop runs; each function names its
 * original. Bit-identical results need the same IEEE double operations in the same order:
 *
 *   - every expression keeps the Python's evaluation order (a * b * c is (a * b) * c);
 *   - no contraction into fused multiply-adds (-ffp-contract=off; numba does not fuse either)
 *     and never -ffast-math (refused below);
 *   - double arithmetic in double precision (FLT_EVAL_METHOD == 0: SSE2, not the x87);
 *   - min and max as numba evaluates Python's min(a, b) and max(a, b): b if b < a (b > a),
 *     else a (not fmin/fmax, which treat NaN and -0 otherwise);
 *   - no libm function whose last bits differ between C libraries: the only transcendental
 *     function, the observer's arctan, is fdlibm's algorithm in plain arithmetic (ctrl_atan,
 *     observer/atan.py); fabs is exact everywhere, and isfinite is a test of the exponent bits
 *     (ctrl_isfinite: no __fpclassify call with any C library); the amplitude-following
 *     observer's square root is correctly rounded by IEEE 754, as the instruction (ctrl_sqrt).
 *
 * What a compile-time check cannot see (a contraction default, -funsafe-math-optimizations, an
 * FPU in flush-to-zero or another rounding mode) ctrl_init checks at run time (ctrl_selftest).
 *
 * Worst-case time of a tick: the observer's implicit friction step is a safeguarded Newton
 * iteration of at most CTRL_NEWTON_MAX (60) iterations (docs/export-c.md gives the counts
 * measured on run logs), each one arctan and a division; everything else is straight-line code with loops of fixed length (the observer's
 * CTRL_N_OBS x CTRL_N_OBS matrix-vector product, or the amplitude-following observer's per-mode
 * search of at most CTRL_N_GRID grid points and 2 x 2 blocks, the fault schedule's rows).
 */
#include <float.h>
#include <math.h>
#include <stdint.h>

#include "frictionrt_ctrl.h"
#if CTRL_AMPLITUDE && defined(__SSE2__)
#include <emmintrin.h>                              /* ctrl_sqrt: the SSE2 square root instruction */
#endif

#if !defined(FLT_EVAL_METHOD) || FLT_EVAL_METHOD != 0
#error "frictionrt_ctrl needs FLT_EVAL_METHOD == 0 (doubles evaluated in double precision, e.g. SSE2 rather than the x87)"
#endif
#ifdef __FAST_MATH__
#error "frictionrt_ctrl must not be built with -ffast-math (it reorders and fuses the arithmetic)"
#endif
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

/* ---- the design's constant types (the Python NamedTuples they mirror) ------------------------ */

typedef struct { double b0, b1, b2, a1, a2; } biquad_params;      /* tracking/lowpass.py BiquadParams */

#if CTRL_OBSERVER
typedef struct {                                                   /* observer/kalman.py ObserverParams */
    double A_d[CTRL_N_OBS][CTRL_N_OBS];
    double B_dT[CTRL_N_OBS], M[CTRL_N_OBS], L[CTRL_N_OBS], C_meas[CTRL_N_OBS];
    double C_u[CTRL_N_OBS], C_v[CTRL_N_OBS], CvA[CTRL_N_OBS];
    double beta, D_u, mu, alpha;
} observer_params;
#endif

#if CTRL_AMPLITUDE
typedef struct {                                                   /* observer/amplitude.py AmplitudeParams */
    double grid[CTRL_N_GRID];                       /* a mode's share of u_rel's amplitude [m], ascending */
    double blocks[CTRL_N_OBS / 2][CTRL_N_GRID][7];  /* per mode and grid point: Ad (row-major), bd, participation */
    double scale[CTRL_N_OBS / 2];                   /* |t phi_i| [m per modal unit] */
    double inv_omega[CTRL_N_OBS / 2];               /* 1 / omega_i [s] */
    double k_j[1];                                  /* > 0: the Jenkins joint's stiffness [N/m]; 0: Coulomb
                                                     * (one element: the design record's shape) */
} amplitude_params;
#endif

typedef struct { double a, b; } rt1_params;                        /* tracking/rt1.py RT1Params */

typedef struct {                                                   /* tracking/laws.py LawParams */
    int law;                 /* 0 passive, 1 hysteresis, 2 lyapunov */
    double F_min, F_max, F_passive, K_f, eps;
    rt1_params rt1;
    int hold_voltage;
} law_params;

typedef struct {                                       /* tracking/force_tracking.py ForceTrackingParams */
    double Kp, Ki_dt, d_pole, d_gain, F0, inv_c_v, V_min, V_max;
} tracking_params;

typedef struct {                                       /* rt/loop/supervisor.py SupervisorParams */
    int enable, auto_recover, observe;
    double acc_lo, acc_hi, force_hi;
    int64_t stuck_ticks;
    double dis_N;
    int64_t dis_ticks;
    double innovation, state, err_N;
    int64_t err_ticks;
    double sat_N;
    int64_t sat_ticks, ovr_count, ovr_ticks, clean_ticks;
    double F_min, V_passive;
} supervisor_params;

typedef struct { double F1[3]; } tip_params;           /* plant/sensors.py SensorParams.F1[0]: integrator */

/* The generated constants: P_TIP, P_ORACLE or P_OBSERVER (and P_AMPLITUDE), P_LAW, P_PREFILTER, P_TRACKING,
 * P_SUPERVISOR, P_FORCE_COL, the state at rest CTRL_INITIAL (hexadecimal floating literals:
 * the exact bits of the design) and the checksum's list CTRL_PARAM_LIST. */
#include "ctrl_design.h"

/* ---- constants of the kernels ------------------------------------------------------------------ */

enum { LAW_PASSIVE = 0, LAW_HYSTERESIS = 1, LAW_LYAPUNOV = 2 };

/* readings (plant/sensors.py SENSOR_OUTPUTS) */
enum { R_A_TIP = 0, R_A_FRF = 1, R_V_TIP = 2, R_F_STRAIN = 3, R_F_CELL = 4 };

/* supervisor (rt/loop/supervisor.py): fault codes, fault kinds, schedule columns, state slots */
enum { NONE = 0, SENSOR_NONFINITE = 1, SENSOR_RANGE = 2, SENSOR_STUCK = 3, FORCE_DISAGREE = 4,
       OBSERVER_DIVERGENCE = 5, COMMAND_NONFINITE = 6, TRACKING_ERROR = 7, AMP_SATURATION = 8,
       OVERRUN_BURST = 9 };
enum { K_OBS_MISMATCH = 6 };
enum { S_CODE = 0, S_LATCHED = 1, S_PASSIVE = 2, S_TRIP_TICK = 3, S_CLEAN = 4, S_ERR = 5, S_SAT = 6,
       S_ERR_N = 7, S_SAT_N = 8, S_OVERRAN = 9, S_OVR_N = 10, S_OVR_HEAD = 11, S_DIS_N = 12,
       S_LAST = 13, S_SAME = 13 + CTRL_N_READ, S_GOOD = 13 + 2 * CTRL_N_READ, S_RING = 13 + 3 * CTRL_N_READ };

static const int CHECKED[4] = {0, 1, 3, 4};   /* readings checked (v_tip_meas is derived) */
static const int PARTNER[4] = {1, 0, 4, 3};   /* the other accelerometer / force sensor */

/* ---- isfinite as a bit test (no library call with any C library) ------------------------------- */

typedef union { double d; uint64_t u; } bits64;

static int ctrl_isfinite(double x)
{
    bits64 b;
    b.d = x;
    return (b.u & 0x7ff0000000000000ULL) != 0x7ff0000000000000ULL;   /* exponent not all ones */
}

/* ---- numba's min / max ------------------------------------------------------------------------ */

static double ord_min(double a, double b) { return (b < a) ? b : a; }   /* Python min(a, b) */
static double ord_max(double a, double b) { return (b > a) ? b : a; }   /* Python max(a, b) */

#if CTRL_OBSERVER
/* ---- arctan: fdlibm's s_atan.c (observer/atan.py _atan), < 1 ulp, the same bits everywhere ------ */

static const double ATAN_HI[4] = {0x1.dac670561bb4fp-2, 0x1.921fb54442d18p-1, 0x1.f730bd281f69bp-1,
                                  0x1.921fb54442d18p+0};          /* atan(1/2), atan(1), atan(3/2), pi/2 */
static const double ATAN_LO[4] = {0x1.a2b7f222f65e2p-56, 0x1.1a62633145c07p-55, 0x1.007887af0cbbdp-56,
                                  0x1.1a62633145c07p-54};
static const double AT[11] = {0x1.555555555550dp-2, -0x1.999999998ebc4p-3, 0x1.24924920083ffp-3,
                              -0x1.c71c6fe231671p-4, 0x1.745cdc54c206ep-4, -0x1.3b0f2af749a6dp-4,
                              0x1.10d66a0d03d51p-4, -0x1.dde2d52defd9ap-5, 0x1.97b4b24760debp-5,
                              -0x1.2b4442c6a6c2fp-5, 0x1.0ad3ae322da11p-6};

static double ctrl_atan(double x)
{
    double a, t, z, w, s1, s2, r;
    int i = -1;
    if (x != x)
        return x;                                  /* NaN */
    a = fabs(x);
    if (a >= 0x1p+66)                               /* atan(x) = +-pi/2 to round-off */
        return x > 0.0 ? ATAN_HI[3] + ATAN_LO[3] : -ATAN_HI[3] - ATAN_LO[3];
    if (a < 0x1.cp-2) {                             /* |x| < 7/16 */
        if (a < 0x1p-29)                            /* atan(x) = x to round-off */
            return x;
        t = x;
    } else if (a < 0x1.6p-1) {                      /* 7/16 <= |x| < 11/16 */
        i = 0;
        t = (2.0 * a - 1.0) / (2.0 + a);
    } else if (a < 0x1.3p+0) {                      /* 11/16 <= |x| < 19/16 */
        i = 1;
        t = (a - 1.0) / (a + 1.0);
    } else if (a < 0x1.38p+1) {                     /* 19/16 <= |x| < 39/16 */
        i = 2;
        t = (a - 1.5) / (1.0 + 1.5 * a);
    } else {                                        /* 39/16 <= |x| < 2^66 */
        i = 3;
        t = -1.0 / a;
    }
    z = t * t;
    w = z * z;
    s1 = z * (AT[0] + w * (AT[2] + w * (AT[4] + w * (AT[6] + w * (AT[8] + w * AT[10])))));
    s2 = w * (AT[1] + w * (AT[3] + w * (AT[5] + w * (AT[7] + w * AT[9]))));
    if (i < 0)
        return t - t * (s1 + s2);
    r = ATAN_HI[i] - ((t * (s1 + s2) - ATAN_LO[i]) - t);
    return x > 0.0 ? r : -r;
}
#endif

/* ---- tip velocity (plant/sensors.py _tip_velocity) ------------------------------------------ */

/* The leaky integrator of the measured tip acceleration; a non-finite reading counts as 0. */
static double tip_velocity(double *xs, double a_tip)
{
    const double u0 = xs[1];
    const double a = ctrl_isfinite(a_tip) ? a_tip : 0.0;
    const double v = P_TIP.F1[0] * xs[0] + P_TIP.F1[1] * u0 + P_TIP.F1[2] * (a - u0);
    xs[0] = v;
    xs[1] = a;
    return v;
}

/* ---- biquad low-pass, direct form II transposed (tracking/lowpass.py _biquad_step) ---------- */

static double biquad_step(const biquad_params *p, const double *x, double u, double *x_next)
{
    const double out = p->b0 * u + x[0];
    x_next[0] = p->b1 * u - p->a1 * out + x[1];
    x_next[1] = p->b2 * u - p->a2 * out;
    return out;
}

#if CTRL_OBSERVER
/* ---- observer (observer/step.py) ---------------------------------------------------------------- */

/* f_r = mu F_N (2/pi) arctan(alpha v) [N] and its slope (_friction). */
static double friction(double v, double F_N, double *df)
{
    const double c = P_OBSERVER.mu * F_N * 0x1.45f306dc9c883p-1;   /* 2 / pi */
    const double av = P_OBSERVER.alpha * v;
    *df = c * P_OBSERVER.alpha / (1.0 + av * av);
    return c * ctrl_atan(av);
}

/* Root of g(v) = v - beta f_r(v) - v_star, between 0 and v_star (_implicit_v_iter): safeguarded
 * Newton that stops on an exact root and on a step within tol before the bracket test, at most
 * CTRL_NEWTON_MAX iterations (the tick's worst case). */
static double implicit_v(double v_star, double beta, double F_N)
{
    double lo = ord_min(0.0, v_star);
    double hi = ord_max(0.0, v_star);
    double v = v_star;
    const double tol = 1e-15 * (fabs(v_star) + 1e-12);
    int it;
    for (it = 0; it < CTRL_NEWTON_MAX; ++it) {
        double df, f, g, v_new;
        f = friction(v, F_N, &df);
        g = v - beta * f - v_star;
        if (g == 0.0)
            return v;                              /* an exact root */
        if (g > 0.0)
            hi = v;
        else
            lo = v;
        v_new = v - g / (1.0 - beta * df);
        if (fabs(v_new - v) <= tol)
            return v_new;                          /* converged, before the bracket test */
        if (!(lo < v_new && v_new < hi))
            v_new = 0.5 * (lo + hi);               /* Newton left the bracket: bisect */
        v = v_new;
    }
    return v;
}

#if !CTRL_AMPLITUDE
/* One tick of the observer (_observer_step): y = (u_rel_hat, v_rel_hat, innovation, f_r_hat). */
static void observer_step(const double *x, double y_meas, double F_N, double *x_next, double *y)
{
    const observer_params *p = &P_OBSERVER;
    double e = y_meas, v_hat = 0.0, u_lin = 0.0, v_star = 0.0, df, f_k, v_next, f_next;
    int i, j;
    for (i = 0; i < CTRL_N_OBS; ++i)
        e -= p->C_meas[i] * x[i];
    for (i = 0; i < CTRL_N_OBS; ++i) {
        const double zi = x[i] + p->M[i] * e;
        v_hat += p->C_v[i] * zi;
        u_lin += p->C_u[i] * zi;
        v_star += p->CvA[i] * zi;
    }
    f_k = friction(v_hat, F_N, &df);
    y[0] = u_lin + p->D_u * f_k;
    y[1] = v_hat;
    y[2] = e;
    y[3] = f_k;
    /* time update with the friction at the end-of-tick velocity */
    v_next = implicit_v(v_star, p->beta, F_N);
    f_next = friction(v_next, F_N, &df);
    for (i = 0; i < CTRL_N_OBS; ++i) {              /* A_d z_k|k = A_d x + L e */
        double acc = p->B_dT[i] * f_next + p->L[i] * e;
        for (j = 0; j < CTRL_N_OBS; ++j)
            acc += p->A_d[i][j] * x[j];
        x_next[i] = acc;
    }
}
#endif /* !CTRL_AMPLITUDE */
#endif

#if CTRL_AMPLITUDE
/* ---- the amplitude-following observer (observer/amplitude_step.py) ----------------------------- */

/* sqrt, correctly rounded (IEEE 754 requires it of every implementation, as LLVM's sqrt that numba
 * calls): the instruction itself, so that the object calls no library function (a libm sqrt
 * sets errno for a negative argument, and the compiler keeps the call for it). */
#if defined(__SSE2__)
static double ctrl_sqrt(double x)
{
    return _mm_cvtsd_f64(_mm_sqrt_sd(_mm_setzero_pd(), _mm_set_sd(x)));
}
#elif defined(__aarch64__)
static double ctrl_sqrt(double x)
{
    double r;
    __asm__("fsqrt %d0, %d1" : "=w"(r) : "w"(x));
    return r;
}
#else
static double ctrl_sqrt(double x)
{
    return sqrt(x);                                 /* correctly rounded in any IEEE 754 (C99 Annex F) libm */
}
#endif

static double clamp_q(double f, double q)          /* _clamp: f into [-q, q] */
{
    return f > q ? q : (f < -q ? -q : f);
}

/* One tick of the amplitude-following observer (_amplitude_step): the paper's measurement update
 * and outputs, then per mode its blocks interpolated at the mode's amplitude
 * a_i = |t phi_i| sqrt(q_i^2 + (q_i' / omega_i)^2) (mode i's share of the outputs and of the
 * friction's velocity times its interpolated participation), and the time update with the friction at the
 * end-of-tick velocity (or the Jenkins joint's return mapping when k_j > 0). */
static void amplitude_step(const double *x, double y_meas, double F_N, double *x_next, double *y)
{
    const observer_params *p = &P_OBSERVER;
    const amplitude_params *a = &P_AMPLITUDE;
    enum { N = CTRL_N_OBS / 2, G = CTRL_N_GRID };
    double w[CTRL_N_OBS];                           /* the interpolated bd per mode */
    double e = y_meas, v_hat = 0.0, u_lin = 0.0, df, f_k, f_next;
    double v_star = 0.0, beta = 0.0, u_star = 0.0, c_u = p->D_u, s = 0.0;
    const double k_j = a->k_j[0];
    const int jenkins = k_j > 0.0;
    const double q_slip = p->mu * fabs(F_N);
    int i;
    for (i = 0; i < CTRL_N_OBS; ++i)
        e -= p->C_meas[i] * x[i];
    for (i = 0; i < CTRL_N_OBS; ++i) {
        const double zi = x[i] + p->M[i] * e;
        x_next[i] = zi;
        v_hat += p->C_v[i] * zi;
        u_lin += p->C_u[i] * zi;
    }
    /* per mode: the blocks and the participation p_i at its amplitude (the outputs' share of mode i
     * made p_i times; nothing added where p_i = 1), A z into x_next, bd into w */
    for (i = 0; i < N; ++i) {
        const double q = x_next[i], qd = x_next[N + i];
        const double r = qd * a->inv_omega[i];
        const double amp = a->scale[i] * ctrl_sqrt(q * q + r * r);
        const double *b0, *b1;
        double wt, c0, pi, dp, cv, cu, a11, a12, a21, a22;
        int j = 0;
        while (j < G - 2 && amp >= a->grid[j + 1])
            ++j;
        wt = (amp - a->grid[j]) / (a->grid[j + 1] - a->grid[j]);
        if (wt > 1.0)
            wt = 1.0;
        b0 = a->blocks[i][j];
        b1 = a->blocks[i][j + 1];
        c0 = 1.0 - wt;
        pi = b0[6] + wt * (b1[6] - b0[6]);
        dp = pi - 1.0;
        v_hat += dp * (p->C_v[i] * q + p->C_v[N + i] * qd);
        u_lin += dp * (p->C_u[i] * q + p->C_u[N + i] * qd);
        a11 = c0 * b0[0] + wt * b1[0];
        a12 = c0 * b0[1] + wt * b1[1];
        a21 = c0 * b0[2] + wt * b1[2];
        a22 = c0 * b0[3] + wt * b1[3];
        w[i] = c0 * b0[4] + wt * b1[4];
        w[N + i] = c0 * b0[5] + wt * b1[5];
        x_next[i] = a11 * q + a12 * qd;
        x_next[N + i] = a21 * q + a22 * qd;
        cv = pi * p->C_v[N + i];
        cu = pi * p->C_u[i];
        v_star += cv * x_next[N + i];
        beta += cv * w[N + i];
        u_star += cu * x_next[i];
        c_u += cu * w[i];
    }
    if (jenkins) {
        s = x[CTRL_N_OBS];
        f_k = clamp_q(k_j * (u_lin - s) / (1.0 - k_j * p->D_u), q_slip);
    } else {
        f_k = friction(v_hat, F_N, &df);
    }
    y[0] = u_lin + p->D_u * f_k;
    y[1] = v_hat;
    y[2] = e;
    y[3] = f_k;
    if (jenkins) {                                  /* the spring-slider's return mapping, force held */
        f_next = k_j * (u_star - s) / (1.0 - k_j * c_u);
        if (f_next > q_slip || f_next < -q_slip) {
            f_next = clamp_q(f_next, q_slip);
            x_next[CTRL_N_OBS] = u_star + c_u * f_next - f_next / k_j;
        } else {
            x_next[CTRL_N_OBS] = s;
        }
    } else {                                        /* friction at the end-of-tick velocity */
        const double v_next = implicit_v(v_star, beta, F_N);
        f_next = friction(v_next, F_N, &df);
    }
    for (i = 0; i < CTRL_N_OBS; ++i)
        x_next[i] += w[i] * f_next;
}
#endif

/* ---- law and RT1 (tracking/laws.py _laws_step, tracking/rt1.py _rt1_step) ------------------- */

static void laws_step(const double *x, double u_rel, double v_rel, double *x_next, double *y)
{
    const law_params *p = &P_LAW;
    double f;
    const double u0 = p->rt1.a * x[0] + p->rt1.b * fabs(u_rel);   /* RT1: u0 at t_k+1 */
    x_next[0] = u0;
    y[1] = u0;
    if (p->law == LAW_HYSTERESIS) {
        f = p->K_f * y[1];
    } else if (p->law == LAW_LYAPUNOV) {
        const double av = fabs(v_rel);
        if (av >= p->eps)
            f = p->F_max;
        else
            f = ord_max(p->F_max * av / p->eps, p->F_min);
    } else {
        f = p->F_passive;
    }
    y[0] = ord_min(ord_max(f, p->F_min), p->F_max);
}

/* ---- force tracking (tracking/force_tracking.py _force_tracking_step) ------------------------- */

static void force_tracking_step(const double *x, double F_set, double F_meas, double *x_next, double *y)
{
    const tracking_params *p = &P_TRACKING;
    double integ = x[0], v, sat;
    const double e = F_set - F_meas;
    const double d = p->d_pole * x[1] - p->d_gain * (F_meas - x[2]);
    const double v_free = (F_set - p->F0) * p->inv_c_v + p->Kp * e + d;   /* all but the integral */
    const double hi = p->V_max - v_free;
    const double lo = p->V_min - v_free;
    const double di = p->Ki_dt * e;
    const double trial = integ + di;
    if (di > 0.0 && trial > hi)        /* conditional integration: up to the limit, never beyond */
        integ = ord_max(integ, hi);
    else if (di < 0.0 && trial < lo)
        integ = ord_min(integ, lo);
    else
        integ = trial;
    if (integ >= hi) {
        v = p->V_max;
        sat = 1.0;
    } else if (integ <= lo) {
        v = p->V_min;
        sat = -1.0;
    } else {
        v = v_free + integ;
        sat = 0.0;
    }
    x_next[0] = integ;
    x_next[1] = d;
    x_next[2] = F_meas;
    y[0] = v;
    y[1] = sat;
}

/* ---- supervisor (rt/loop/supervisor.py) ------------------------------------------------------- */

/* yc[i] = ys[i] if finite, else the last finite reading of sensor i (_sanitise). */
static void sanitise(double *s, const double *ys, double *yc)
{
    int i;
    for (i = 0; i < CTRL_N_READ; ++i) {
        if (ctrl_isfinite(ys[i]))
            s[S_GOOD + i] = ys[i];
        yc[i] = s[S_GOOD + i];
    }
}

/* The first failing check's code, counters advanced (_check). z: the observer's next state. */
static int check(int64_t k, double *s, const double *ys, const double *ye, const double *z, double F_set)
{
    const supervisor_params *p = &P_SUPERVISOR;
    int code = NONE, j, c;
    double e, sat;
    for (j = 0; j < 4; ++j) {
        const int i = CHECKED[j];
        if (ys[i] == s[S_LAST + i])
            s[S_SAME + i] += 1.0;
        else
            s[S_SAME + i] = 0.0;
        s[S_LAST + i] = ys[i];
    }
    for (j = 0; j < 4; ++j) {
        const int i = CHECKED[j];
        const double v = ys[i];
        if (!ctrl_isfinite(v))
            c = SENSOR_NONFINITE;
        else if ((i < 2 && (v <= p->acc_lo || v >= p->acc_hi)) || (i >= 2 && (v <= 0.0 || v >= p->force_hi)))
            c = SENSOR_RANGE;
        else if (s[S_SAME + i] >= (double)p->stuck_ticks && s[S_SAME + PARTNER[j]] < (double)p->stuck_ticks)
            c = SENSOR_STUCK;
        else
            c = NONE;
        if (c != NONE && (code == NONE || c < code))
            code = c;
    }
    s[S_DIS_N] = fabs(ys[R_F_STRAIN] - ys[R_F_CELL]) > p->dis_N ? s[S_DIS_N] + 1.0 : 0.0;
    if (code == NONE && s[S_DIS_N] > (double)p->dis_ticks)
        code = FORCE_DISAGREE;
    /* estimator */
    if (code == NONE) {
        int bad = !(ctrl_isfinite(ye[0]) && ctrl_isfinite(ye[1]));
        if (p->observe) {
#if CTRL_OBSERVER
            double n2 = 0.0;
            int i;
            for (i = 0; i < CTRL_N_STATE; ++i)
                n2 += z[i] * z[i];
            bad = bad || !(fabs(ye[2]) <= p->innovation && n2 <= p->state * p->state);
#endif
        }
        if (bad)
            code = OBSERVER_DIVERGENCE;
        else if (!ctrl_isfinite(F_set))
            code = COMMAND_NONFINITE;
    }
    (void)z;
    /* force tracking of the previous tick */
    e = s[S_ERR];
    sat = s[S_SAT];
    s[S_ERR_N] = fabs(e) > p->err_N ? s[S_ERR_N] + 1.0 : 0.0;
    s[S_SAT_N] = (sat != 0.0 && sat * e > p->sat_N) ? s[S_SAT_N] + 1.0 : 0.0;
    if (code == NONE) {
        if (s[S_ERR_N] > (double)p->err_ticks)
            code = TRACKING_ERROR;
        else if (s[S_SAT_N] > (double)p->sat_ticks)
            code = AMP_SATURATION;
    }
    /* overruns: ring of the last ovr_count overrunning ticks */
    if (s[S_OVERRAN] != 0.0) {
        int64_t h = (int64_t)s[S_OVR_HEAD];
        s[S_RING + h] = (double)(k - 1);           /* the tick that overran */
        h = (h + 1) % p->ovr_count;
        s[S_OVR_HEAD] = (double)h;
        s[S_OVR_N] = ord_min(s[S_OVR_N] + 1.0, (double)p->ovr_count);
        if (code == NONE && s[S_OVR_N] >= (double)p->ovr_count
            && (double)(k - 1) - s[S_RING + h] < (double)p->ovr_ticks)
            code = OVERRUN_BURST;
    }
    return code;
}

/* Latch a fault (go passive) or count clean ticks towards auto recovery (_latch). */
static void latch(int64_t k, double *s, int code)
{
    const supervisor_params *p = &P_SUPERVISOR;
    s[S_CODE] = (double)code;
    if (!p->enable)
        return;
    if (s[S_PASSIVE] == 0.0) {
        if (code != NONE) {
            s[S_PASSIVE] = 1.0;
            s[S_LATCHED] = (double)code;
            s[S_TRIP_TICK] = (double)k;
            s[S_CLEAN] = 0.0;
        }
    } else if (p->auto_recover) {
        s[S_CLEAN] = code == NONE ? s[S_CLEAN] + 1.0 : 0.0;
        if (s[S_CLEAN] >= (double)p->clean_ticks) {
            s[S_PASSIVE] = 0.0;
            s[S_LATCHED] = 0.0;
            s[S_CLEAN] = 0.0;
        }
    }
}

/* Tick k's checks and latch; the setpoint for the force tracking (_supervise). */
static double supervise(int64_t k, double *s, const double *ys, const double *ye, const double *z, double F_set)
{
    latch(k, s, check(k, s, ys, ye, z, F_set));
    if (s[S_PASSIVE] != 0.0 || !ctrl_isfinite(F_set))
        return P_SUPERVISOR.F_min;
    return F_set;
}

/* After the force tracking: record error and saturation, guard V_cmd (_supervise_after). */
static void supervise_after(int64_t k, double *s, double e, double *yf, double *y)
{
    s[S_ERR] = ctrl_isfinite(e) ? e : 0.0;
    s[S_SAT] = yf[1];
    if (!ctrl_isfinite(yf[0])) {
        yf[0] = P_SUPERVISOR.V_passive;
        if (s[S_CODE] == NONE)
            latch(k, s, COMMAND_NONFINITE);
    }
    y[0] = s[S_CODE];
    y[1] = s[S_LATCHED];
    y[2] = s[S_PASSIVE];
}

#if CTRL_OBSERVER
/* observer_mismatch at tick k: the observer's tip-velocity input times value (_inject_observer). */
static double inject_observer(int64_t k, const ctrl_fault *F, int n, double v)
{
    int r;
    for (r = 0; r < n; ++r)
        if ((int64_t)F[r].kind == K_OBS_MISMATCH && F[r].k_start <= (double)k && (double)k < F[r].k_end)
            v *= F[r].value;
    return v;
}
#endif

/* ---- the tick (rt/loop/tick.py _controller_tick, _controller_done) ---------------------------- */

/* ---- the guards (ctrl_selftest) --------------------------------------------------------------- */

/* Each operand is read from a volatile, so the compiler cannot fold the expression; each result
 * is exact in IEEE double arithmetic as written and differs when the build computes otherwise. */
static int arithmetic_selftest(void)
{
    volatile double a = 0x1.00000004p+0, b = 0x1.fffffff8p-1, c = -1.0;   /* 1 + 2^-30, 1 - 2^-30 */
    volatile double big = 0x1p+53, one = 1.0, three = 3.0, five = 5.0, seven = 7.0;
    volatile double tiny = 0x1p-1022, half = 0.5, ulp_half = 0x1p-53, odd = 0x1.0000000000001p+0;
    volatile double r;
    double acc;
    r = a * b + c;                    /* a b = 1 - 2^-60 rounds to 1: 0; fused: -2^-60 */
    if (r != 0.0)
        return CTRL_ERR_CONTRACTION;
    acc = c;
    acc += a * b;                     /* the accumulation form of the matrix-vector products */
    r = acc;
    if (r != 0.0)
        return CTRL_ERR_CONTRACTION;
    acc = big;                        /* one read: the compiler knows both uses are one value */
    r = (acc + one) - acc;            /* 2^53 + 1 rounds to 2^53: 0; reassociated: 1 */
    if (r != 0.0)
        return CTRL_ERR_REASSOCIATION;
    acc = three;                      /* one divisor used thrice: what -freciprocal-math turns into 1/3 */
    r = five / acc + one / acc + seven / acc;   /* correctly rounded quotients; times 1/3 one ulp lower */
    if (r != 0x1.1555555555556p+2)
        return CTRL_ERR_RECIPROCAL;
    r = tiny * half;                  /* 2^-1023, subnormal; flushed: 0 */
    if (r != 0x1p-1023)
        return CTRL_ERR_SUBNORMAL;
    r = one + ulp_half;               /* a tie: to even, 1 (upward: 1 + 2^-52) */
    if (r != 1.0)
        return CTRL_ERR_ROUNDING;
    r = -one - ulp_half;              /* a tie: to even, -1 (downward: -1 - 2^-52) */
    if (r != -1.0)
        return CTRL_ERR_ROUNDING;
    r = odd + ulp_half;               /* a tie from an odd mantissa: to even, 1 + 2^-51 (toward zero: 1 + 2^-52) */
    if (r != 0x1.0000000000002p+0)
        return CTRL_ERR_ROUNDING;
    return CTRL_OK;
}

/* FNV-1a 64 of one value, as the 8 little-endian bytes of a double. */
static uint64_t fnv_double(uint64_t h, double x)
{
    bits64 b;
    int j;
    b.d = x;
    for (j = 0; j < 8; ++j) {                        /* little-endian bytes, whatever the target's order */
        h ^= (b.u >> (8 * j)) & 0xffU;
        h *= 0x100000001b3ULL;                       /* FNV-1a 64: prime */
    }
    return h;
}

static uint64_t sum_double(uint64_t h, const double *p, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        h = fnv_double(h, p[i]);
    return h;
}

static uint64_t sum_int(uint64_t h, const int *p, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        h = fnv_double(h, (double)p[i]);
    return h;
}

static uint64_t sum_int64(uint64_t h, const int64_t *p, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        h = fnv_double(h, (double)p[i]);
    return h;
}

uint64_t ctrl_param_checksum(void)
{
    uint64_t h = 0xcbf29ce484222325ULL;            /* FNV-1a 64: offset basis */
#define CTRL_SUM(kind, n, p) h = sum_##kind(h, p, n);
    CTRL_PARAM_LIST(CTRL_SUM)
#undef CTRL_SUM
    return h;
}

int ctrl_selftest(void)
{
    const int rc = arithmetic_selftest();
    if (rc != CTRL_OK)
        return rc;
    if (ctrl_param_checksum() != CTRL_PARAM_CHECKSUM)
        return CTRL_ERR_CHECKSUM;
    return CTRL_OK;
}

const char *ctrl_error_text(int code)
{
    switch (code) {
    case CTRL_OK: return "ok";
    case CTRL_ERR_CONTRACTION: return "the build fuses multiply-adds (build with -ffp-contract=off)";
    case CTRL_ERR_REASSOCIATION: return "the build reassociates additions (no -ffast-math, -funsafe-math-optimizations, -fassociative-math)";
    case CTRL_ERR_RECIPROCAL: return "the build replaces divisions by reciprocals (no -freciprocal-math)";
    case CTRL_ERR_SUBNORMAL: return "the FPU flushes subnormals to zero (clear the flush-to-zero / denormals-are-zero mode)";
    case CTRL_ERR_ROUNDING: return "the FPU does not round to nearest even (set the default rounding mode)";
    case CTRL_ERR_CHECKSUM: return "the parameters differ from the design (ctrl_design.h edited: export again)";
    default: return "unknown error";
    }
}

int ctrl_init(ctrl_state *s)
{
    *s = CTRL_INITIAL;
    return ctrl_selftest();
}

const char *ctrl_design_hash(void)
{
    return CTRL_DESIGN_HASH;
}

void ctrl_step(ctrl_state *s, const ctrl_inputs *in, ctrl_outputs *out)
{
    const int64_t k = in->k;
    double ys[CTRL_N_READ], yc[CTRL_N_READ];   /* the readings; those the controller uses */
    double ye[4], yl[2], yq, yf[2], ysv[3];     /* the stages' outputs */
    double xl_n[1], xq_n[2], xf_n[3];           /* their next states */
    double F_set, e;
    int passive;
#if CTRL_OBSERVER
    double xe_n[CTRL_N_STATE];
    const double *z = xe_n;
#else
    double xo_n[4];
    const double *z = 0;
#endif
    /* 1 (end of the sensor stage) the controller's tip integrator on the ADC reading */
    ys[R_A_TIP] = in->a_tip_meas;
    ys[R_A_FRF] = in->a_frf_meas;
    ys[R_V_TIP] = tip_velocity(s->xs, in->a_tip_meas);
    ys[R_F_STRAIN] = in->F_strain;
    ys[R_F_CELL] = in->F_cell;
    s->sv[S_OVERRAN] = in->overran ? 1.0 : 0.0;
    /* 2 estimator, on the sanitised readings */
    sanitise(s->sv, ys, yc);
#if CTRL_OBSERVER
#if CTRL_AMPLITUDE
    amplitude_step(s->xe, inject_observer(k, in->faults, in->n_faults, yc[R_V_TIP]), yc[R_F_CELL], xe_n, ye);
#else
    observer_step(s->xe, inject_observer(k, in->faults, in->n_faults, yc[R_V_TIP]), yc[R_F_CELL], xe_n, ye);
#endif
#else
    ye[0] = biquad_step(&P_ORACLE, s->xo, in->u_rel, xo_n);
    ye[1] = biquad_step(&P_ORACLE, s->xo + 2, in->v_rel, xo_n + 2);
    ye[2] = 0.0;
    ye[3] = 0.0;
#endif
    /* 3 law */
    laws_step(s->xl, ye[0], ye[1], xl_n, yl);
    /* 3s supervisor: the setpoint the tracking gets (F_min when passive) */
    F_set = supervise(k, s->sv, ys, ye, z, yl[0]);
    passive = s->sv[S_PASSIVE] != 0.0;
    /* 4 prefilter and force tracking on the law's sensor; passive: integral reset and held at 0 */
    yq = biquad_step(&P_PREFILTER, s->xq, F_set, xq_n);
    if (passive)
        s->xf[0] = 0.0;
    force_tracking_step(s->xf, yq, yc[P_FORCE_COL], xf_n, yf);
    if (passive) {
        xf_n[0] = 0.0;
    } else if (P_LAW.hold_voltage) {   /* the passive law holds the stack at the feedforward voltage */
        yf[0] = ord_min(ord_max((yq - P_TRACKING.F0) * P_TRACKING.inv_c_v, P_TRACKING.V_min), P_TRACKING.V_max);
        yf[1] = 0.0;
        xf_n[0] = 0.0;
    }
    e = (P_LAW.hold_voltage && !passive) ? 0.0 : yq - yc[P_FORCE_COL];   /* a held stack does not track */
    supervise_after(k, s->sv, e, yf, ysv);
    /* outputs, and the next states become the states */
    out->v_tip_meas = ys[R_V_TIP];
    out->u_rel_hat = ye[0];
    out->v_rel_hat = ye[1];
    out->innovation = ye[2];
    out->f_r_hat = ye[3];
    out->F_set = yl[0];
    out->u0 = yl[1];
    out->F_set_filtered = yq;
    out->V_cmd = yf[0];
    out->saturated = yf[1];
    out->fault_code = ysv[0];
    out->fault_latched = ysv[1];
    out->passive = ysv[2];
    {
        int i;
#if CTRL_OBSERVER
        for (i = 0; i < CTRL_N_STATE; ++i)
            s->xe[i] = xe_n[i];
#else
        for (i = 0; i < 4; ++i)
            s->xo[i] = xo_n[i];
#endif
        s->xl[0] = xl_n[0];
        for (i = 0; i < 2; ++i)
            s->xq[i] = xq_n[i];
        for (i = 0; i < 3; ++i)
            s->xf[i] = xf_n[i];
    }
}
