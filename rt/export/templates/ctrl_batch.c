/*
 * ctrl_batch.c: the exported controller over a whole recorded sensor stream in one call.
 *
 * `frictionrt replay LOG.mcap --c DIR` builds this with frictionrt_ctrl.c into a shared library
 * and calls ctrl_run through ctypes (one foreign call per log, not per tick). A target does not
 * need this file.
 */
#define _POSIX_C_SOURCE 199309L   /* clock_gettime for ctrl_run_timed, where the C library has it */
#include <stddef.h>
#include <string.h>
#include <time.h>
#if defined(CLOCK_MONOTONIC)
#define CTRL_HAVE_CLOCK 1
#else
#define CTRL_HAVE_CLOCK 0         /* e.g. newlib (arm-none-eabi): ctrl_run_timed reports -1 ns */
#endif

#include "frictionrt_ctrl.h"

/* Run ticks k[0] .. k[n-1] from the state at rest (ctrl_init):
 *   sens     n x 4 readings per tick: a_tip_meas, a_frf_meas, F_strain, F_cell
 *   uv       n x 2 the plant's u_rel, v_rel (the oracle's test build; ignored, may be NULL, otherwise)
 *   overran  n flags: the tick before overran (0 or 1)
 *   faults   n_faults rows of the fault schedule (may be NULL when n_faults is 0)
 *   out      n x CTRL_N_OUTPUTS: the outputs in ctrl_outputs order
 * Returns the number of ticks run (n), or minus ctrl_init's CTRL_ERR_ code (nothing run). */
int64_t ctrl_run_timed(int64_t n, const int64_t *k, const double *sens, const double *uv, const double *overran,
                       const ctrl_fault *faults, int n_faults, double *out, int64_t *ns);

int64_t ctrl_run(int64_t n, const int64_t *k, const double *sens, const double *uv, const double *overran,
                 const ctrl_fault *faults, int n_faults, double *out)
{
    return ctrl_run_timed(n, k, sens, uv, overran, faults, n_faults, out, NULL);
}

static int64_t run_ticks(int64_t n, const int64_t *k, const double *sens, const double *uv, const double *overran,
                         const ctrl_fault *faults, int n_faults, double *out, int64_t *ns,
                         int64_t n_restart, const int64_t *restart_at, const double *states);

/* As ctrl_run; with ns not NULL, ns[i] receives the time of tick i's ctrl_step [ns]
 * (CLOCK_MONOTONIC around the call: `frictionrt bench controller --c DIR`). */
int64_t ctrl_run_timed(int64_t n, const int64_t *k, const double *sens, const double *uv, const double *overran,
                       const ctrl_fault *faults, int n_faults, double *out, int64_t *ns)
{
    return run_ticks(n, k, sens, uv, overran, faults, n_faults, out, ns, 0, NULL, NULL);
}

/* As ctrl_run, and before tick i = restart_at[r] (increasing) the state is set to states[r], an
 * image of ctrl_state (ctrl_state_size() bytes, doubles only: ctrl_state_offsets) the caller built
 * from a log's key frame: a replay that restarts after a gap in the log (`frictionrt replay
 * LOG.mcap --c DIR`). The members and the key frame's parts: docs/export-c.md. */
int64_t ctrl_run_restarts(int64_t n, const int64_t *k, const double *sens, const double *uv, const double *overran,
                          const ctrl_fault *faults, int n_faults, double *out,
                          int64_t n_restart, const int64_t *restart_at, const double *states)
{
    return run_ticks(n, k, sens, uv, overran, faults, n_faults, out, NULL, n_restart, restart_at, states);
}

static int64_t run_ticks(int64_t n, const int64_t *k, const double *sens, const double *uv, const double *overran,
                         const ctrl_fault *faults, int n_faults, double *out, int64_t *ns,
                         int64_t n_restart, const int64_t *restart_at, const double *states)
{
    ctrl_state s;
    ctrl_inputs in;
    ctrl_outputs y;
    int64_t i, r = 0;
    const int rc = ctrl_init(&s);
    if (rc != CTRL_OK)
        return -(int64_t)rc;
    in.faults = faults;
    in.n_faults = n_faults;
    for (i = 0; i < n; ++i) {
        double *o = out + i * CTRL_N_OUTPUTS;
        if (r < n_restart && restart_at[r] == i) {
            memcpy(&s, states + r * (int64_t)(sizeof(ctrl_state) / sizeof(double)), sizeof(ctrl_state));
            ++r;
        }
        in.k = k[i];
        in.a_tip_meas = sens[4 * i];
        in.a_frf_meas = sens[4 * i + 1];
        in.F_strain = sens[4 * i + 2];
        in.F_cell = sens[4 * i + 3];
        in.overran = overran[i] != 0.0;
#if !CTRL_OBSERVER
        in.u_rel = uv[2 * i];
        in.v_rel = uv[2 * i + 1];
#else
        (void)uv;
#endif
        if (ns != NULL) {
#if CTRL_HAVE_CLOCK
            struct timespec t0, t1;
            clock_gettime(CLOCK_MONOTONIC, &t0);
            ctrl_step(&s, &in, &y);
            clock_gettime(CLOCK_MONOTONIC, &t1);
            ns[i] = (int64_t)(t1.tv_sec - t0.tv_sec) * 1000000000 + (int64_t)(t1.tv_nsec - t0.tv_nsec);
#else
            ctrl_step(&s, &in, &y);
            ns[i] = -1;
#endif
        } else {
            ctrl_step(&s, &in, &y);
        }
        o[0] = y.v_tip_meas;
        o[1] = y.u_rel_hat;
        o[2] = y.v_rel_hat;
        o[3] = y.innovation;
        o[4] = y.f_r_hat;
        o[5] = y.F_set;
        o[6] = y.u0;
        o[7] = y.F_set_filtered;
        o[8] = y.V_cmd;
        o[9] = y.saturated;
        o[10] = y.fault_code;
        o[11] = y.fault_latched;
        o[12] = y.passive;
    }
    return n;
}

/* The state at rest into the caller's buffer of ctrl_state_size() bytes (software in the loop);
 * ctrl_init's CTRL_OK or CTRL_ERR_ code. */
int ctrl_init_flat(void *state)
{
    return ctrl_init((ctrl_state *)state);
}

/* One tick through flat arrays, for a caller that cannot build the structs (the numba loop of
 * `frictionrt simulate --controller c:DIR`): in = (k, a_tip_meas, a_frf_meas, F_strain, F_cell,
 * overran, u_rel, v_rel), faults = n_faults rows of 5, out = the CTRL_N_OUTPUTS outputs. */
void ctrl_step_flat(void *state, const double *in, const double *faults, int64_t n_faults, double *out)
{
    ctrl_inputs x;
    ctrl_outputs y;
    x.k = (int64_t)in[0];
    x.a_tip_meas = in[1];
    x.a_frf_meas = in[2];
    x.F_strain = in[3];
    x.F_cell = in[4];
    x.overran = in[5] != 0.0;
    x.faults = (const ctrl_fault *)faults;
    x.n_faults = (int)n_faults;
#if !CTRL_OBSERVER
    x.u_rel = in[6];
    x.v_rel = in[7];
#endif
    ctrl_step((ctrl_state *)state, &x, &y);
    out[0] = y.v_tip_meas;
    out[1] = y.u_rel_hat;
    out[2] = y.v_rel_hat;
    out[3] = y.innovation;
    out[4] = y.f_r_hat;
    out[5] = y.F_set;
    out[6] = y.u0;
    out[7] = y.F_set_filtered;
    out[8] = y.V_cmd;
    out[9] = y.saturated;
    out[10] = y.fault_code;
    out[11] = y.fault_latched;
    out[12] = y.passive;
}

/* Where ctrl_state's members lie, in doubles from its start: off[0] xs, off[1] the estimator's
 * state (xe or xo), off[2] xl, off[3] xq, off[4] xf, off[5] sv, off[6] the end (sizeof). Software
 * in the loop moves the state between ctrl_state and the loop's own arrays with them, so that a
 * run starts from, and leaves, the loop's state. */
void ctrl_state_offsets(int64_t *off)
{
    off[0] = (int64_t)(offsetof(ctrl_state, xs) / sizeof(double));
#if CTRL_OBSERVER
    off[1] = (int64_t)(offsetof(ctrl_state, xe) / sizeof(double));
#else
    off[1] = (int64_t)(offsetof(ctrl_state, xo) / sizeof(double));
#endif
    off[2] = (int64_t)(offsetof(ctrl_state, xl) / sizeof(double));
    off[3] = (int64_t)(offsetof(ctrl_state, xq) / sizeof(double));
    off[4] = (int64_t)(offsetof(ctrl_state, xf) / sizeof(double));
    off[5] = (int64_t)(offsetof(ctrl_state, sv) / sizeof(double));
    off[6] = (int64_t)(sizeof(ctrl_state) / sizeof(double));
}

/* sizeof(ctrl_state), for the caller's check of the build it loaded. */
int64_t ctrl_state_size(void)
{
    return (int64_t)sizeof(ctrl_state);
}
