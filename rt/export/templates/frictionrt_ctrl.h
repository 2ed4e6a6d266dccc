/*
 * frictionrt_ctrl.h: the frictionrt controller of one configuration as plain C99.
 *
 * Exported by `frictionrt export-c` (docs/export-c.md). One call of ctrl_step is one tick of
 * the 21 kHz loop between the sensor readings and the commanded voltage: the tip velocity
 * integrator, the estimator (the paper's nonlinear observer, its amplitude-following kind, or in a
 * test build the oracle), the law
 * (passive, hysteresis-optimal with RT1, Lyapunov), the supervisor, the setpoint prefilter and
 * the force tracking (feedforward + PID with anti-windup and limits, or the passive law's
 * voltage hold). It computes, bit for bit, what the numba controller of frictionrt computes
 * (rt/loop/tick.py _controller_tick); `frictionrt replay LOG.mcap --c DIR` proves it on a log.
 *
 * The DAC, the amplifier, the sensors' analog parts and the ADCs stay on the target: the
 * inputs are the ADC readings in SI units, the output V_cmd is the voltage for the DAC [V].
 *
 * No heap, no mutable globals, re-entrant: every state lives in a ctrl_state the caller owns
 * (one per controller instance); the design constants are read-only (const) data.
 */
#ifndef FRICTIONRT_CTRL_H
#define FRICTIONRT_CTRL_H

#include <stdint.h>

#include "ctrl_config.h"   /* generated: sizes, the estimator, the design hash */

/* The supervisor's state: SUPERVISOR_SLOTS of rt/loop/supervisor.py (13 scalars, then the last,
 * unchanged-count and last finite reading of each of the 5 readings, then the overrun ring). */
#define CTRL_N_READ 5
#define CTRL_RING 64
#define CTRL_N_SUP (13 + 3 * CTRL_N_READ + CTRL_RING)

/* Every state of the controller between two ticks. */
typedef struct ctrl_state {
    double xs[2];            /* tip integrator: v_tip [m/s], previous a_tip_meas [m/s^2] */
#if CTRL_OBSERVER
    double xe[CTRL_N_STATE]; /* observer: a-priori state z_k|k-1 (observer/step.py, observer/amplitude_step.py;
                              * with the Jenkins joint the slider's position last) */
#else
    double xo[4];            /* oracle low-pass: (s1, s2) of u_rel, of v_rel (test build) */
#endif
    double xl[1];            /* RT1 amplitude u0 [m] */
    double xq[2];            /* setpoint prefilter (s1, s2) [N] */
    double xf[3];            /* PID: integral [V], derivative [V], previous F_meas [N] */
    double sv[CTRL_N_SUP];   /* supervisor (counters and ticks as exact integers) */
} ctrl_state;

/* One row of the fault schedule (rt/loop/supervisor.py, F_KIND .. F_VALUE). The controller acts
 * on kind 6, observer_mismatch (the observer's tip-velocity input times value) while
 * k_start <= k < k_end; every other kind acts outside it (sensors, amplifier) and is ignored. */
typedef struct ctrl_fault {
    double kind, target, k_start, k_end, value;
} ctrl_fault;

/* The inputs of tick k. */
typedef struct ctrl_inputs {
    int64_t k;               /* the tick: t_k = k / CTRL_RATE_HZ */
    double a_tip_meas;       /* tip acceleration ADC reading [m/s^2] (NaN: a dropout) */
    double a_frf_meas;       /* FRF-point acceleration ADC reading [m/s^2] */
    double F_strain;         /* strain-gauge bolt force reading [N] */
    double F_cell;           /* piezo force-cell bolt force reading [N] */
    int overran;             /* 1 if the tick before overran its period (paced), else 0 */
    const ctrl_fault *faults;   /* the fault schedule (may be NULL when n_faults is 0) */
    int n_faults;
#if !CTRL_OBSERVER
    double u_rel, v_rel;     /* test build only: the plant's true u_rel [m], v_rel [m/s] */
#endif
} ctrl_inputs;

/* The outputs of tick k (every commanded signal of the loop's log, in its order). */
typedef struct ctrl_outputs {
    double v_tip_meas;       /* integrated tip velocity [m/s] */
    double u_rel_hat;        /* estimated relative displacement at the damper [m] */
    double v_rel_hat;        /* estimated relative velocity [m/s] */
    double innovation;       /* observer innovation [m/s] (0 for the oracle) */
    double f_r_hat;          /* observer friction force [N] (0 for the oracle) */
    double F_set;            /* the law's normal-force setpoint F* [N] */
    double u0;               /* RT1 slip amplitude [m] */
    double F_set_filtered;   /* prefiltered setpoint [N] (F_min while passive) */
    double V_cmd;            /* the commanded piezo voltage for the DAC [V] */
    double saturated;        /* +1 at V_max, -1 at V_min, 0 inside */
    double fault_code;       /* this tick's first failing check (0 none) */
    double fault_latched;    /* the latched fault code (0 while active) */
    double passive;          /* 1 while the supervisor holds the passive F_min */
} ctrl_outputs;

#define CTRL_N_OUTPUTS 13

/* What ctrl_init returns: CTRL_OK, or the first guard that failed (the build must not run). */
enum {
    CTRL_OK = 0,
    CTRL_ERR_CONTRACTION = 1,    /* a * b + c was fused (FMA contraction: -ffp-contract=fast, gnu11 defaults) */
    CTRL_ERR_REASSOCIATION = 2,  /* (a + b) - a was simplified (-fassociative-math, -funsafe-math-optimizations) */
    CTRL_ERR_RECIPROCAL = 3,     /* a / b became a * (1 / b) (-freciprocal-math) */
    CTRL_ERR_SUBNORMAL = 4,      /* subnormals flushed to zero (FPU flush-to-zero or denormals-are-zero mode) */
    CTRL_ERR_ROUNDING = 5,       /* the rounding mode is not round-to-nearest-even */
    CTRL_ERR_CHECKSUM = 6        /* the parameters' checksum differs from CTRL_PARAM_CHECKSUM (ctrl_design.h edited) */
};

/* The state at rest (the plant at its preload equilibrium at F0, every filter at steady state),
 * after the guards (ctrl_selftest): returns CTRL_OK, or a CTRL_ERR_ code and then the build
 * would not compute the design's bits: do not run it. */
int ctrl_init(ctrl_state *s);

/* The guards alone: a short computation on volatile inputs whose result changes when the
 * compiler fuses or reassociates the arithmetic or the FPU flushes subnormals or rounds
 * otherwise, then the parameters' checksum. CTRL_OK or the first failing CTRL_ERR_ code. */
int ctrl_selftest(void);

/* The checksum of the parameters and the state at rest as this build holds them: FNV-1a 64 over
 * the design record's values in its key order, each as the 8 little-endian bytes of a double
 * (integers converted), so no struct padding or byte order enters it. */
uint64_t ctrl_param_checksum(void);

/* A CTRL_ERR_ code in words. */
const char *ctrl_error_text(int code);

/* One tick: reads *in, advances *s, writes *out. in and out must not alias s. */
void ctrl_step(ctrl_state *s, const ctrl_inputs *in, ctrl_outputs *out);

/* The design hash of the exported configuration ("sha256:..."), CTRL_DESIGN_HASH. */
const char *ctrl_design_hash(void);

#endif /* FRICTIONRT_CTRL_H */
