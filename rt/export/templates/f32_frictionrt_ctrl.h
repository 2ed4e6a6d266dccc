/*
 * frictionrt_ctrl.h (float32 kind): the frictionrt controller of one configuration as plain C99
 * in single precision, for a core with a single-precision FPU only (Cortex-M4F: fpv4-sp-d16).
 *
 * Exported by `frictionrt export-c --precision float32` (docs/export-c.md, "The float32 kind").
 * The same tick as the double kind (tip integrator, observer, law, supervisor, prefilter, force
 * tracking), every operation in IEEE binary32, the observer's state update in delta form per mode
 * (x_next = x + D x + ..., D = A_d - I on each mode's 2 x 2 block), so that its poles, a few
 * hundred float32 ulps inside the unit circle and more, survive the rounding of the parameters. Its outputs are not the
 * double controller's bits: they lie within the stated bound of it (docs/export-c.md) and equal,
 * bit for bit, the float32 golden outputs of the export (`make check`).
 *
 * No heap, no mutable globals, re-entrant: every state lives in a ctrl_state the caller owns.
 * No double arithmetic in ctrl_step (build with -Wdouble-promotion to see it stays so).
 */
#ifndef FRICTIONRT_CTRL_H
#define FRICTIONRT_CTRL_H

#include <stdint.h>

#include "ctrl_config.h"   /* generated: sizes, the design hash, CTRL_PRECISION_FLOAT32 */

#define CTRL_N_READ 5
#define CTRL_RING 64

/* The supervisor's state (rt/loop/supervisor.py SUPERVISOR_SLOTS, typed: counts and ticks as
 * integers, so that they stay exact for any run length). */
typedef struct ctrl_supervisor {
    int32_t code, latched, passive, clean;   /* this tick's code, the latched one, passive flag, clean ticks */
    int64_t trip_tick;                       /* the tick the fault latched */
    float err, sat;                          /* the previous tick's tracking error [N], saturation flag */
    int32_t err_n, sat_n, overran, ovr_n, ovr_head, dis_n;
    float last[CTRL_N_READ];                 /* the previous reading of each sensor */
    int32_t same[CTRL_N_READ];               /* ticks each reading has not changed */
    float good[CTRL_N_READ];                 /* the last finite reading of each sensor */
    int64_t ring[CTRL_RING];                 /* the last overrunning ticks */
} ctrl_supervisor;

/* Every state of the controller between two ticks. */
typedef struct ctrl_state {
    float xs[2];             /* tip integrator: v_tip [m/s], previous a_tip_meas [m/s^2] */
    float xe[CTRL_N_OBS];    /* observer: a-priori state z_k|k-1, the double kind's coordinates */
    float xl[1];             /* RT1 amplitude u0 [m] */
    float xq[2];             /* setpoint prefilter (s1, s2) [N] */
    float xf[3];             /* PID: integral [V], derivative [V], previous F_meas [N] */
    ctrl_supervisor sv;      /* supervisor */
} ctrl_state;

/* One row of the fault schedule, as the double kind's (on a rig none: n_faults = 0). */
typedef struct ctrl_fault {
    double kind, target, k_start, k_end, value;
} ctrl_fault;

/* The inputs of tick k. */
typedef struct ctrl_inputs {
    int64_t k;               /* the tick: t_k = k / CTRL_RATE_HZ */
    float a_tip_meas;        /* tip acceleration ADC reading [m/s^2] (NaN: a dropout) */
    float a_frf_meas;        /* FRF-point acceleration ADC reading [m/s^2] */
    float F_strain;          /* strain-gauge bolt force reading [N] */
    float F_cell;            /* piezo force-cell bolt force reading [N] */
    int overran;             /* 1 if the tick before overran its period (paced), else 0 */
    const ctrl_fault *faults;   /* the fault schedule (may be NULL when n_faults is 0) */
    int n_faults;
} ctrl_inputs;

/* The outputs of tick k (the double kind's, in its order). */
typedef struct ctrl_outputs {
    float v_tip_meas, u_rel_hat, v_rel_hat, innovation, f_r_hat, F_set, u0, F_set_filtered, V_cmd;
    float saturated, fault_code, fault_latched, passive;
} ctrl_outputs;

#define CTRL_N_OUTPUTS 13

enum {
    CTRL_OK = 0,
    CTRL_ERR_CONTRACTION = 1,    /* a * b + c was fused (-ffp-contract=fast, gnu11 defaults) */
    CTRL_ERR_REASSOCIATION = 2,  /* (a + b) - a was simplified (-fassociative-math, -funsafe-math-optimizations) */
    CTRL_ERR_RECIPROCAL = 3,     /* a / b became a * (1 / b) (-freciprocal-math) */
    CTRL_ERR_SUBNORMAL = 4,      /* subnormals flushed to zero (FPSCR.FZ, MXCSR FTZ/DAZ) */
    CTRL_ERR_ROUNDING = 5,       /* the rounding mode is not round-to-nearest-even */
    CTRL_ERR_CHECKSUM = 6        /* the parameters' checksum differs from CTRL_PARAM_CHECKSUM (ctrl_design.h edited) */
};

int ctrl_init(ctrl_state *s);                 /* the state at rest after the guards: CTRL_OK or CTRL_ERR_ */
int ctrl_selftest(void);                      /* the guards alone */
uint64_t ctrl_param_checksum(void);           /* FNV-1a 64 over the float32 parameters (4 little-endian bytes each) */
const char *ctrl_error_text(int code);
void ctrl_step(ctrl_state *s, const ctrl_inputs *in, ctrl_outputs *out);
const char *ctrl_design_hash(void);           /* the double design it was made from, CTRL_DESIGN_HASH */

#endif /* FRICTIONRT_CTRL_H */
