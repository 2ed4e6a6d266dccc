/*
 * frictionrt_ctrl.c (float32 kind): one tick of the frictionrt controller in single precision
 * (frictionrt_ctrl.h). The double kind's transcription of the numba kernels, each function naming
 * its original, with every value and operation in IEEE binary32 and three changes of realisation:
 *
 *   - the observer's time update in delta form per mode: A_d is block diagonal in the design's
 *     modal coordinates (each mode's displacement and velocity), and each 2 x 2 block is stored
 *     as D = A_d - I (computed in double at export time, then rounded), x_next = x + (D x + L e +
 *     B f): the poles 1 + eig(D) keep their frequency and damping to the relative rounding of D's
 *     small entries; A_d's own entries rounded to float32 lose the digits that place the poles
 *     (the slowest lies 244 float32 ulps inside the unit circle): docs/export-c.md gives the pole
 *     error of both per mode;
 *   - the tip integrator and RT1's amplitude filter in the same delta form (poles 1 - 6e-4 and
 *     1 - 2.4e-3: rounding a, not a - 1, would change their DC gains by up to 1e-4 and 3e-5);
 *   - the setpoint prefilter's b1 chosen at export time so that b0 + b1 + b2 = 1 + a1 + a2 with the
 *     rounded coefficients (its DC gain 1 to 3e-8, where rounding each alone gives 1e-6: 40 uN at
 *     40 N, which the force tracking's integral would sum);
 *   - the Newton step of the implicit friction stops on a step within 4 float32 ulps of v* (the
 *     double kind's 1e-15 relative is below float32's resolution), at most CTRL_NEWTON_MAX
 *     iterations; the arctan is fdlibm's single-precision s_atanf.c (< 1 ulp);
 *   - the supervisor's counts and ticks are integers (exact for any run length).
 *
 * Bit-identical results between builds (the golden vectors) need the same binary32 operations in
 * the same order: no contraction (-ffp-contract=off), never -ffast-math, FLT_EVAL_METHOD == 0
 * (floats evaluated in single precision), no double promotion (every literal has an f suffix).
 */
#include <float.h>
#include <math.h>
#include <stdint.h>

#include "frictionrt_ctrl.h"

#if !defined(FLT_EVAL_METHOD) || FLT_EVAL_METHOD != 0
#error "frictionrt_ctrl needs FLT_EVAL_METHOD == 0 (floats evaluated in single precision)"
#endif
#ifdef __FAST_MATH__
#error "frictionrt_ctrl must not be built with -ffast-math (it reorders and fuses the arithmetic)"
#endif
#if defined(__clang__)
#pragma STDC FP_CONTRACT OFF
#endif

/* ---- the design's constant types -------------------------------------------------------------- */

typedef struct { float b0, b1, b2, a1, a2; } biquad_params;

typedef struct {
    int16_t blk[CTRL_N_BLK][2];          /* the states (i, j) of each mode's 2 x 2 block */
    float D[CTRL_N_BLK][4];              /* A_d - I on the block: d_ii, d_ij, d_ji, d_jj */
    float B_dT[CTRL_N_OBS], M[CTRL_N_OBS], L[CTRL_N_OBS], C_meas[CTRL_N_OBS];
    float C_u[CTRL_N_OBS], C_v[CTRL_N_OBS], CvA[CTRL_N_OBS];
    float beta, D_u, mu, alpha;
} observer_params;

typedef struct { float am1, b; } rt1_params;                 /* RT1's a - 1 (delta form), b */

typedef struct {
    int law;
    float F_min, F_max, F_passive, K_f, eps;
    rt1_params rt1;
    int hold_voltage;
} law_params;

typedef struct { float Kp, Ki_dt, d_pole, d_gain, F0, inv_c_v, V_min, V_max; } tracking_params;

typedef struct {
    int enable, auto_recover, observe;
    float acc_lo, acc_hi, force_hi;
    int32_t stuck_ticks;
    float dis_N;
    int32_t dis_ticks;
    float innovation, state, err_N;
    int32_t err_ticks;
    float sat_N;
    int32_t sat_ticks, ovr_count, ovr_ticks, clean_ticks;
    float F_min, V_passive;
} supervisor_params;

typedef struct { float d0, f1, f2; } tip_params;   /* F1[0] - 1, F1[1], F1[2] of the leaky integrator */

/* The generated constants (float32 values as hexadecimal floating literals, each the nearest
 * float to the design's double: a delta-form entry is rounded from its double difference). */
#include "ctrl_design.h"

enum { LAW_PASSIVE = 0, LAW_HYSTERESIS = 1, LAW_LYAPUNOV = 2 };
enum { R_A_TIP = 0, R_A_FRF = 1, R_V_TIP = 2, R_F_STRAIN = 3, R_F_CELL = 4 };
enum { NONE = 0, SENSOR_NONFINITE = 1, SENSOR_RANGE = 2, SENSOR_STUCK = 3, FORCE_DISAGREE = 4,
       OBSERVER_DIVERGENCE = 5, COMMAND_NONFINITE = 6, TRACKING_ERROR = 7, AMP_SATURATION = 8,
       OVERRUN_BURST = 9 };
enum { K_OBS_MISMATCH = 6 };

static const int CHECKED[4] = {0, 1, 3, 4};
static const int PARTNER[4] = {1, 0, 4, 3};

typedef union { float f; uint32_t u; } bits32;

static int ctrl_isfinite(float x)
{
    bits32 b;
    b.f = x;
    return (b.u & 0x7f800000U) != 0x7f800000U;
}

static float ord_min(float a, float b) { return (b < a) ? b : a; }
static float ord_max(float a, float b) { return (b > a) ? b : a; }
static int32_t inc(int32_t n) { return n < INT32_MAX ? n + 1 : n; }   /* a count that saturates */

/* ---- arctan: fdlibm's s_atanf.c (FreeBSD), < 1 ulp ------------------------------------------------ */

static const float ATAN_HI[4] = {4.6364760399e-01f, 7.8539812565e-01f, 9.8279368877e-01f, 1.5707962513e+00f};
static const float ATAN_LO[4] = {5.0121582440e-09f, 3.7748947079e-08f, 3.4473217170e-08f, 7.5497894159e-08f};
static const float AT[5] = {3.3333328366e-01f, -1.9999158382e-01f, 1.4253635705e-01f, -1.0648017377e-01f,
                            6.1687607318e-02f};

static float ctrl_atanf(float x)
{
    float a, t, z, w, s1, s2, r;
    int i = -1;
    if (x != x)
        return x;
    a = fabsf(x);
    if (a >= 0x1p+26f)
        return x > 0.0f ? ATAN_HI[3] + ATAN_LO[3] : -ATAN_HI[3] - ATAN_LO[3];
    if (a < 0x1.cp-2f) {                             /* |x| < 7/16 */
        if (a < 0x1p-12f)
            return x;
        t = x;
    } else if (a < 0x1.6p-1f) {                      /* < 11/16 */
        i = 0;
        t = (2.0f * a - 1.0f) / (2.0f + a);
    } else if (a < 0x1.3p+0f) {                      /* < 19/16 */
        i = 1;
        t = (a - 1.0f) / (a + 1.0f);
    } else if (a < 0x1.38p+1f) {                     /* < 39/16 */
        i = 2;
        t = (a - 1.5f) / (1.0f + 1.5f * a);
    } else {
        i = 3;
        t = -1.0f / a;
    }
    z = t * t;
    w = z * z;
    s1 = z * (AT[0] + w * (AT[2] + w * AT[4]));
    s2 = w * (AT[1] + w * AT[3]);
    if (i < 0)
        return t - t * (s1 + s2);
    r = ATAN_HI[i] - ((t * (s1 + s2) - ATAN_LO[i]) - t);
    return x > 0.0f ? r : -r;
}

/* ---- tip velocity (plant/sensors.py _tip_velocity), in delta form ------------------------------ */

static float tip_velocity(float *xs, float a_tip)
{
    const float u0 = xs[1];
    const float a = ctrl_isfinite(a_tip) ? a_tip : 0.0f;
    const float v = xs[0] + (P_TIP.d0 * xs[0] + P_TIP.f1 * u0 + P_TIP.f2 * (a - u0));
    xs[0] = v;
    xs[1] = a;
    return v;
}

static float biquad_step(const biquad_params *p, const float *x, float u, float *x_next)
{
    const float out = p->b0 * u + x[0];
    x_next[0] = p->b1 * u - p->a1 * out + x[1];
    x_next[1] = p->b2 * u - p->a2 * out;
    return out;
}

/* ---- observer (observer/step.py) ---------------------------------------------------------------- */

static float friction(float v, float F_N, float *df)
{
    const float c = P_OBSERVER.mu * F_N * 0x1.45f306p-1f;   /* 2 / pi */
    const float av = P_OBSERVER.alpha * v;
    *df = c * P_OBSERVER.alpha / (1.0f + av * av);
    return c * ctrl_atanf(av);
}

/* Root of g(v) = v - beta f_r(v) - v_star between 0 and v_star: safeguarded Newton, stops on an
 * exact root or a step within 4 ulps of |v_star| (plus 1e-12 m/s), at most CTRL_NEWTON_MAX. */
static float implicit_v(float v_star, float beta, float F_N)
{
    float lo = ord_min(0.0f, v_star);
    float hi = ord_max(0.0f, v_star);
    float v = v_star;
    const float tol = 0x1p-22f * (fabsf(v_star) + 1e-12f);
    int it;
    for (it = 0; it < CTRL_NEWTON_MAX; ++it) {
        float df, f, g, v_new;
        f = friction(v, F_N, &df);
        g = v - beta * f - v_star;
        if (g == 0.0f)
            return v;
        if (g > 0.0f)
            hi = v;
        else
            lo = v;
        v_new = v - g / (1.0f - beta * df);
        if (fabsf(v_new - v) <= tol)
            return v_new;
        if (!(lo < v_new && v_new < hi))
            v_new = 0.5f * (lo + hi);
        v = v_new;
    }
    return v;
}

static void observer_step(const float *x, float y_meas, float F_N, float *x_next, float *y)
{
    const observer_params *p = &P_OBSERVER;
    float e = y_meas, v_hat = 0.0f, u_lin = 0.0f, v_star = 0.0f, df, f_k, v_next, f_next;
    int i, b;
    for (i = 0; i < CTRL_N_OBS; ++i)
        e -= p->C_meas[i] * x[i];
    for (i = 0; i < CTRL_N_OBS; ++i) {
        const float zi = x[i] + p->M[i] * e;
        v_hat += p->C_v[i] * zi;
        u_lin += p->C_u[i] * zi;
        v_star += p->CvA[i] * zi;
    }
    f_k = friction(v_hat, F_N, &df);
    y[0] = u_lin + p->D_u * f_k;
    y[1] = v_hat;
    y[2] = e;
    y[3] = f_k;
    v_next = implicit_v(v_star, p->beta, F_N);
    f_next = friction(v_next, F_N, &df);
    for (b = 0; b < CTRL_N_BLK; ++b) {               /* x_next = x + (D x + L e + B f) per mode */
        const int i0 = p->blk[b][0], i1 = p->blk[b][1];
        const float x0 = x[i0], x1 = x[i1];
        const float d0 = p->D[b][0] * x0 + p->D[b][1] * x1 + p->L[i0] * e + p->B_dT[i0] * f_next;
        const float d1 = p->D[b][2] * x0 + p->D[b][3] * x1 + p->L[i1] * e + p->B_dT[i1] * f_next;
        x_next[i0] = x0 + d0;
        x_next[i1] = x1 + d1;
    }
}

/* ---- law, force tracking -------------------------------------------------------------------------- */

static void laws_step(const float *x, float u_rel, float v_rel, float *x_next, float *y)
{
    const law_params *p = &P_LAW;
    float f;
    const float u0 = x[0] + (p->rt1.am1 * x[0] + p->rt1.b * fabsf(u_rel));   /* RT1 in delta form */
    x_next[0] = u0;
    y[1] = u0;
    if (p->law == LAW_HYSTERESIS) {
        f = p->K_f * y[1];
    } else if (p->law == LAW_LYAPUNOV) {
        const float av = fabsf(v_rel);
        if (av >= p->eps)
            f = p->F_max;
        else
            f = ord_max(p->F_max * av / p->eps, p->F_min);
    } else {
        f = p->F_passive;
    }
    y[0] = ord_min(ord_max(f, p->F_min), p->F_max);
}

static void force_tracking_step(const float *x, float F_set, float F_meas, float *x_next, float *y)
{
    const tracking_params *p = &P_TRACKING;
    float integ = x[0], v, sat;
    const float e = F_set - F_meas;
    const float d = p->d_pole * x[1] - p->d_gain * (F_meas - x[2]);
    const float v_free = (F_set - p->F0) * p->inv_c_v + p->Kp * e + d;
    const float hi = p->V_max - v_free;
    const float lo = p->V_min - v_free;
    const float di = p->Ki_dt * e;
    const float trial = integ + di;
    if (di > 0.0f && trial > hi)
        integ = ord_max(integ, hi);
    else if (di < 0.0f && trial < lo)
        integ = ord_min(integ, lo);
    else
        integ = trial;
    if (integ >= hi) {
        v = p->V_max;
        sat = 1.0f;
    } else if (integ <= lo) {
        v = p->V_min;
        sat = -1.0f;
    } else {
        v = v_free + integ;
        sat = 0.0f;
    }
    x_next[0] = integ;
    x_next[1] = d;
    x_next[2] = F_meas;
    y[0] = v;
    y[1] = sat;
}

/* ---- supervisor (rt/loop/supervisor.py) ------------------------------------------------------- */

static void sanitise(ctrl_supervisor *s, const float *ys, float *yc)
{
    int i;
    for (i = 0; i < CTRL_N_READ; ++i) {
        if (ctrl_isfinite(ys[i]))
            s->good[i] = ys[i];
        yc[i] = s->good[i];
    }
}

static int check(int64_t k, ctrl_supervisor *s, const float *ys, const float *ye, const float *z, float F_set)
{
    const supervisor_params *p = &P_SUPERVISOR;
    int code = NONE, j, c;
    float e, sat;
    for (j = 0; j < 4; ++j) {
        const int i = CHECKED[j];
        s->same[i] = ys[i] == s->last[i] ? inc(s->same[i]) : 0;
        s->last[i] = ys[i];
    }
    for (j = 0; j < 4; ++j) {
        const int i = CHECKED[j];
        const float v = ys[i];
        if (!ctrl_isfinite(v))
            c = SENSOR_NONFINITE;
        else if ((i < 2 && (v <= p->acc_lo || v >= p->acc_hi)) || (i >= 2 && (v <= 0.0f || v >= p->force_hi)))
            c = SENSOR_RANGE;
        else if (s->same[i] >= p->stuck_ticks && s->same[PARTNER[j]] < p->stuck_ticks)
            c = SENSOR_STUCK;
        else
            c = NONE;
        if (c != NONE && (code == NONE || c < code))
            code = c;
    }
    s->dis_n = fabsf(ys[R_F_STRAIN] - ys[R_F_CELL]) > p->dis_N ? inc(s->dis_n) : 0;
    if (code == NONE && s->dis_n > p->dis_ticks)
        code = FORCE_DISAGREE;
    if (code == NONE) {
        int bad = !(ctrl_isfinite(ye[0]) && ctrl_isfinite(ye[1]));
        if (p->observe) {
            float n2 = 0.0f;
            int i;
            for (i = 0; i < CTRL_N_OBS; ++i)
                n2 += z[i] * z[i];
            bad = bad || !(fabsf(ye[2]) <= p->innovation && n2 <= p->state * p->state);
        }
        if (bad)
            code = OBSERVER_DIVERGENCE;
        else if (!ctrl_isfinite(F_set))
            code = COMMAND_NONFINITE;
    }
    e = s->err;
    sat = s->sat;
    s->err_n = fabsf(e) > p->err_N ? inc(s->err_n) : 0;
    s->sat_n = (sat != 0.0f && sat * e > p->sat_N) ? inc(s->sat_n) : 0;
    if (code == NONE) {
        if (s->err_n > p->err_ticks)
            code = TRACKING_ERROR;
        else if (s->sat_n > p->sat_ticks)
            code = AMP_SATURATION;
    }
    if (s->overran) {
        int32_t h = s->ovr_head;
        s->ring[h] = k - 1;
        h = (h + 1) % p->ovr_count;
        s->ovr_head = h;
        s->ovr_n = s->ovr_n + 1 < p->ovr_count ? s->ovr_n + 1 : p->ovr_count;
        if (code == NONE && s->ovr_n >= p->ovr_count && (k - 1) - s->ring[h] < (int64_t)p->ovr_ticks)
            code = OVERRUN_BURST;
    }
    return code;
}

static void latch(int64_t k, ctrl_supervisor *s, int code)
{
    const supervisor_params *p = &P_SUPERVISOR;
    s->code = code;
    if (!p->enable)
        return;
    if (!s->passive) {
        if (code != NONE) {
            s->passive = 1;
            s->latched = code;
            s->trip_tick = k;
            s->clean = 0;
        }
    } else if (p->auto_recover) {
        s->clean = code == NONE ? inc(s->clean) : 0;
        if (s->clean >= p->clean_ticks) {
            s->passive = 0;
            s->latched = 0;
            s->clean = 0;
        }
    }
}

static float supervise(int64_t k, ctrl_supervisor *s, const float *ys, const float *ye, const float *z, float F_set)
{
    latch(k, s, check(k, s, ys, ye, z, F_set));
    if (s->passive || !ctrl_isfinite(F_set))
        return P_SUPERVISOR.F_min;
    return F_set;
}

static void supervise_after(int64_t k, ctrl_supervisor *s, float e, float *yf, float *y)
{
    s->err = ctrl_isfinite(e) ? e : 0.0f;
    s->sat = yf[1];
    if (!ctrl_isfinite(yf[0])) {
        yf[0] = P_SUPERVISOR.V_passive;
        if (s->code == NONE)
            latch(k, s, COMMAND_NONFINITE);
    }
    y[0] = (float)s->code;
    y[1] = (float)s->latched;
    y[2] = (float)s->passive;
}

static float inject_observer(int64_t k, const ctrl_fault *F, int n, float v)
{
    int r;
    for (r = 0; r < n; ++r)
        if ((int64_t)F[r].kind == K_OBS_MISMATCH && F[r].k_start <= (double)k && (double)k < F[r].k_end)
            v *= (float)F[r].value;
    return v;
}

/* ---- the guards (ctrl_selftest): binary32 counterparts of the double kind's -------------------- */

static int arithmetic_selftest(void)
{
    volatile float a = 0x1.0002p+0f, b = 0x1.fffcp-1f, c = -1.0f;    /* 1 + 2^-15, 1 - 2^-15 */
    volatile float big = 0x1p+24f, one = 1.0f, three = 3.0f, five = 5.0f, seven = 7.0f;
    volatile float tiny = 0x1p-126f, half = 0.5f, ulp_half = 0x1p-24f, odd = 0x1.000002p+0f;
    volatile float r;
    float acc;
    r = a * b + c;                    /* a b = 1 - 2^-30 rounds to 1: 0; fused: -2^-30 */
    if (r != 0.0f)
        return CTRL_ERR_CONTRACTION;
    acc = c;
    acc += a * b;
    r = acc;
    if (r != 0.0f)
        return CTRL_ERR_CONTRACTION;
    acc = big;
    r = (acc + one) - acc;            /* 2^24 + 1 rounds to 2^24: 0; reassociated: 1 */
    if (r != 0.0f)
        return CTRL_ERR_REASSOCIATION;
    acc = three;
    r = five / acc + one / acc + seven / acc;
    if (r != CTRL_RECIPROCAL_SUM)
        return CTRL_ERR_RECIPROCAL;
    r = tiny * half;                  /* 2^-127, subnormal; flushed: 0 */
    if (r != 0x1p-127f)
        return CTRL_ERR_SUBNORMAL;
    r = one + ulp_half;
    if (r != 1.0f)
        return CTRL_ERR_ROUNDING;
    r = -one - ulp_half;
    if (r != -1.0f)
        return CTRL_ERR_ROUNDING;
    r = odd + ulp_half;               /* to even: 1 + 2^-22 */
    if (r != 0x1.000004p+0f)
        return CTRL_ERR_ROUNDING;
    return CTRL_OK;
}

/* FNV-1a 64 of one value as the 4 little-endian bytes of a float (integers converted). */
static uint64_t fnv_float(uint64_t h, float x)
{
    bits32 b;
    int j;
    b.f = x;
    for (j = 0; j < 4; ++j) {
        h ^= (b.u >> (8 * j)) & 0xffU;
        h *= 0x100000001b3ULL;
    }
    return h;
}

static uint64_t sum_float(uint64_t h, const float *p, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        h = fnv_float(h, p[i]);
    return h;
}

static uint64_t sum_int(uint64_t h, const int *p, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        h = fnv_float(h, (float)p[i]);
    return h;
}

static uint64_t sum_int16(uint64_t h, const int16_t *p, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        h = fnv_float(h, (float)p[i]);
    return h;
}

static uint64_t sum_int32(uint64_t h, const int32_t *p, int n)
{
    int i;
    for (i = 0; i < n; ++i)
        h = fnv_float(h, (float)p[i]);
    return h;
}

uint64_t ctrl_param_checksum(void)
{
    uint64_t h = 0xcbf29ce484222325ULL;
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

/* ---- the tick (rt/loop/tick.py _controller_tick, _controller_done) ---------------------------- */

void ctrl_step(ctrl_state *s, const ctrl_inputs *in, ctrl_outputs *out)
{
    const int64_t k = in->k;
    float ys[CTRL_N_READ], yc[CTRL_N_READ];
    float ye[4], yl[2], yq, yf[2], ysv[3];
    float xl_n[1], xq_n[2], xf_n[3], xe_n[CTRL_N_OBS];
    float F_set, e;
    int passive, i;
    ys[R_A_TIP] = in->a_tip_meas;
    ys[R_A_FRF] = in->a_frf_meas;
    ys[R_V_TIP] = tip_velocity(s->xs, in->a_tip_meas);
    ys[R_F_STRAIN] = in->F_strain;
    ys[R_F_CELL] = in->F_cell;
    s->sv.overran = in->overran ? 1 : 0;
    sanitise(&s->sv, ys, yc);
    observer_step(s->xe, inject_observer(k, in->faults, in->n_faults, yc[R_V_TIP]), yc[R_F_CELL], xe_n, ye);
    laws_step(s->xl, ye[0], ye[1], xl_n, yl);
    F_set = supervise(k, &s->sv, ys, ye, xe_n, yl[0]);
    passive = s->sv.passive != 0;
    yq = biquad_step(&P_PREFILTER, s->xq, F_set, xq_n);
    if (passive)
        s->xf[0] = 0.0f;
    force_tracking_step(s->xf, yq, yc[P_FORCE_COL], xf_n, yf);
    if (passive) {
        xf_n[0] = 0.0f;
    } else if (P_LAW.hold_voltage) {
        yf[0] = ord_min(ord_max((yq - P_TRACKING.F0) * P_TRACKING.inv_c_v, P_TRACKING.V_min), P_TRACKING.V_max);
        yf[1] = 0.0f;
        xf_n[0] = 0.0f;
    }
    e = (P_LAW.hold_voltage && !passive) ? 0.0f : yq - yc[P_FORCE_COL];
    supervise_after(k, &s->sv, e, yf, ysv);
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
    for (i = 0; i < CTRL_N_OBS; ++i)
        s->xe[i] = xe_n[i];
    s->xl[0] = xl_n[0];
    for (i = 0; i < 2; ++i)
        s->xq[i] = xq_n[i];
    for (i = 0; i < 3; ++i)
        s->xf[i] = xf_n[i];
}
