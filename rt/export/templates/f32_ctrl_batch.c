/*
 * ctrl_batch.c (float32 kind): the exported controller over a whole recorded sensor stream in one
 * call, with the double kind's signature (doubles in and out: each reading rounded to float, each
 * output widened exactly), so that `frictionrt replay LOG.mcap --c DIR` measures its difference
 * from the double controller. A target does not need this file.
 */
#include <stddef.h>

#include "frictionrt_ctrl.h"

int64_t ctrl_run(int64_t n, const int64_t *k, const double *sens, const double *uv, const double *overran,
                 const ctrl_fault *faults, int n_faults, double *out)
{
    ctrl_state s;
    ctrl_inputs in;
    ctrl_outputs y;
    int64_t i;
    const int rc = ctrl_init(&s);
    (void)uv;
    if (rc != CTRL_OK)
        return -(int64_t)rc;
    in.faults = faults;
    in.n_faults = n_faults;
    for (i = 0; i < n; ++i) {
        double *o = out + i * CTRL_N_OUTPUTS;
        in.k = k[i];
        in.a_tip_meas = (float)sens[4 * i];
        in.a_frf_meas = (float)sens[4 * i + 1];
        in.F_strain = (float)sens[4 * i + 2];
        in.F_cell = (float)sens[4 * i + 3];
        in.overran = overran[i] != 0.0;
        ctrl_step(&s, &in, &y);
        o[0] = y.v_tip_meas; o[1] = y.u_rel_hat; o[2] = y.v_rel_hat; o[3] = y.innovation; o[4] = y.f_r_hat;
        o[5] = y.F_set; o[6] = y.u0; o[7] = y.F_set_filtered; o[8] = y.V_cmd; o[9] = y.saturated;
        o[10] = y.fault_code; o[11] = y.fault_latched; o[12] = y.passive;
    }
    return n;
}

/* sizeof(ctrl_state), for the caller's check of the build it loaded. */
int64_t ctrl_state_size(void)
{
    return (int64_t)sizeof(ctrl_state);
}
