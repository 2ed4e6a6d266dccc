/*
 * ctrl_harness.c: the exported controller as a command-line filter, for a machine without Python.
 *
 *   ./ctrl_harness < readings.txt > outputs.txt
 *
 * Input: one tick per line, whitespace-separated numbers (decimal or C99 hexadecimal, nan, inf):
 *
 *   k a_tip_meas a_frf_meas F_strain F_cell overran            (observer build)
 *   k a_tip_meas a_frf_meas F_strain F_cell overran u_rel v_rel (oracle test build)
 *
 * in SI units (m/s^2, N, m, m/s), overran 0 or 1; blank lines and lines starting with '#' are
 * skipped. Output: a header line, then per tick k and the CTRL_N_OUTPUTS outputs as hexadecimal
 * floats (printf %a: the exact bits). The controller starts at rest (ctrl_init) and runs without
 * faults. Exit 1 with a message naming the line for a line it cannot read.
 */
#include <stdio.h>
#include <string.h>

#include "frictionrt_ctrl.h"

int main(void)
{
    char line[1024];
    long lineno = 0;
    ctrl_state s;
    ctrl_inputs in;
    ctrl_outputs y;
    {
        const int rc = ctrl_init(&s);
        if (rc != CTRL_OK) {
            fprintf(stderr, "ctrl_harness: ctrl_init: %s\n", ctrl_error_text(rc));
            return 1;
        }
    }
    memset(&in, 0, sizeof in);
    in.faults = NULL;
    in.n_faults = 0;
    printf("# frictionrt controller %s\n", ctrl_design_hash());
    printf("# k v_tip_meas u_rel_hat v_rel_hat innovation f_r_hat F_set u0 F_set_filtered V_cmd saturated "
           "fault_code fault_latched passive\n");
    while (fgets(line, sizeof line, stdin) != NULL) {
        long long k;
        int overran, n;
        double u_rel = 0.0, v_rel = 0.0;
        ++lineno;
        if (line[strspn(line, " \t\r\n")] == '\0' || line[strspn(line, " \t")] == '#')
            continue;
        n = sscanf(line, "%lld %lf %lf %lf %lf %d %lf %lf", &k, &in.a_tip_meas, &in.a_frf_meas, &in.F_strain,
                   &in.F_cell, &overran, &u_rel, &v_rel);
        if (n != (CTRL_OBSERVER ? 6 : 8)) {
            fprintf(stderr, "ctrl_harness: line %ld: expected %s\n", lineno,
                    CTRL_OBSERVER ? "k a_tip_meas a_frf_meas F_strain F_cell overran"
                                  : "k a_tip_meas a_frf_meas F_strain F_cell overran u_rel v_rel");
            return 1;
        }
        in.k = (int64_t)k;
        in.overran = overran != 0;
#if !CTRL_OBSERVER
        in.u_rel = u_rel;
        in.v_rel = v_rel;
#endif
        ctrl_step(&s, &in, &y);
        printf("%lld %a %a %a %a %a %a %a %a %a %a %a %a %a\n", k, y.v_tip_meas, y.u_rel_hat, y.v_rel_hat,
               y.innovation, y.f_r_hat, y.F_set, y.u0, y.F_set_filtered, y.V_cmd, y.saturated, y.fault_code,
               y.fault_latched, y.passive);
    }
    return 0;
}
