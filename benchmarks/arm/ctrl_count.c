/*
 * ctrl_count.c: the export's golden inputs through ctrl_step, the first N ticks, for counting the
 * instructions of each tick under qemu-arm (benchmarks/arm_target.py). Builds with either kind of
 * export (the double kind's inputs are doubles, the float32 kind's floats: the assignment rounds).
 *
 *   ctrl_count golden_in.txt N
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "frictionrt_ctrl.h"

typedef union { double d; uint64_t u; } bits64;

int main(int argc, char **argv)
{
    char line[512];
    FILE *f;
    ctrl_state s;
    ctrl_inputs in;
    ctrl_outputs y;
    long n = 0, limit;
    int rc;
    if (argc != 3)
        return 2;
    limit = strtol(argv[2], NULL, 10);
    f = fopen(argv[1], "r");
    if (f == NULL)
        return 2;
    rc = ctrl_init(&s);
    if (rc != CTRL_OK) {
        printf("FAIL ctrl_init %d\n", rc);
        return 1;
    }
    memset(&in, 0, sizeof in);
    while (n < limit && fgets(line, sizeof line, f) != NULL) {
        uint64_t v[6];
        char *p = line, *end;
        int i;
        bits64 b;
        if (line[0] == '#')
            continue;
        for (i = 0; i < 6; ++i) {
            v[i] = (uint64_t)strtoull(p, &end, 16);
            p = end;
        }
        in.k = (int64_t)v[0];
        b.u = v[1]; in.a_tip_meas = b.d;
        b.u = v[2]; in.a_frf_meas = b.d;
        b.u = v[3]; in.F_strain = b.d;
        b.u = v[4]; in.F_cell = b.d;
        in.overran = v[5] != 0;
        ctrl_step(&s, &in, &y);
        ++n;
    }
    printf("ticks %ld V_cmd %g\n", n, (double)y.V_cmd);
    return 0;
}
