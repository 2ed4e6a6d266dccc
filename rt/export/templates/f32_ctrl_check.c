/*
 * ctrl_check.c (float32 kind): the export's golden vectors through the compiled controller, bit for bit.
 * The readings are doubles, rounded to float as a target's ADC scaling would give them; the
 * expected outputs are the float32 bits of the export's host build (the export's own outputs).
 *
 *   ./ctrl_check golden_in.txt golden_out.txt          (make check)
 *
 * golden_in.txt: per tick k, the four ADC readings and the overrun flag (oracle build: and the
 * plant's u_rel, v_rel), golden_out.txt: the CTRL_N_OUTPUTS expected outputs; every number a
 * hexadecimal integer, the readings and outputs the raw bits of IEEE 754 doubles (readings) and binary32 floats (outputs, 8 hexadecimal digits). The driver
 * needs only fopen, fgets, strtoull and printf of unsigned longs: it runs on newlib (no
 * hexadecimal floating input or output, no %llx needed) and under qemu-user or semihosting.
 *
 * Prints one line and exits 0 when ctrl_init's guards pass and every output of every tick has
 * the expected bits; otherwise exits 1 naming the guard, or the first tick and output that
 * differ with both bit patterns, or the line it cannot read.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "frictionrt_ctrl.h"

static const char *const NAMES[CTRL_N_OUTPUTS] = {
    "v_tip_meas", "u_rel_hat", "v_rel_hat", "innovation", "f_r_hat", "F_set", "u0", "F_set_filtered",
    "V_cmd", "saturated", "fault_code", "fault_latched", "passive"};

typedef union { double d; uint64_t u; } bits64;
typedef union { float f; uint32_t u; } bits32;

/* Reads the next data line of f into v[0..n-1] (hexadecimal integers); 1 on success, 0 at the
 * end of the file, -1 for a line without n numbers. Comment lines naming a design are checked. */
static int read_row(FILE *f, uint64_t *v, int n, long *lineno, const char *file)
{
    char line[512];
    while (fgets(line, sizeof line, f) != NULL) {
        char *p = line, *end;
        int i;
        ++*lineno;
        if (line[strspn(line, " \t\r\n")] == '\0')
            continue;
        if (line[0] == '#') {
            const char *tag = "# frictionrt golden ";
            if (strncmp(line, tag, strlen(tag)) == 0) {
                const char *h = line + strlen(tag), *want = ctrl_design_hash();
                if (strncmp(h, want, strlen(want)) != 0) {
                    printf("FAIL %s: golden vectors of another design (%.27s...), this build is %.27s...\n",
                           file, h, want);
                    return -2;
                }
            }
            continue;
        }
        for (i = 0; i < n; ++i) {
            unsigned long long x = strtoull(p, &end, 16);
            if (end == p) {
                printf("FAIL %s line %ld: expected %d hexadecimal numbers\n", file, *lineno, n);
                return -1;
            }
            v[i] = (uint64_t)x;
            p = end;
        }
        return 1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    enum { N_IN = 6 };
    FILE *fi, *fo;
    ctrl_state s;
    ctrl_inputs in;
    ctrl_outputs y;
    uint64_t vi[8], vo[CTRL_N_OUTPUTS];
    long li = 0, lo = 0, ticks = 0;
    int rc, ri, ro, j;
    if (argc != 3) {
        printf("usage: ctrl_check golden_in.txt golden_out.txt\n");
        return 2;
    }
    fi = fopen(argv[1], "r");
    fo = fopen(argv[2], "r");
    if (fi == NULL || fo == NULL) {
        printf("FAIL cannot open %s\n", fi == NULL ? argv[1] : argv[2]);
        return 1;
    }
    rc = ctrl_init(&s);
    if (rc != CTRL_OK) {
        printf("FAIL ctrl_init: %s\n", ctrl_error_text(rc));
        return 1;
    }
    memset(&in, 0, sizeof in);
    in.faults = NULL;
    in.n_faults = 0;
    for (;;) {
        bits64 b;
        bits32 c;
        float o[CTRL_N_OUTPUTS];
        ri = read_row(fi, vi, N_IN, &li, argv[1]);
        ro = read_row(fo, vo, CTRL_N_OUTPUTS, &lo, argv[2]);
        if (ri < 0 || ro < 0)
            return 1;
        if (ri == 0 || ro == 0) {
            if (ri != ro) {
                printf("FAIL %s ends before %s\n", ri == 0 ? argv[1] : argv[2], ri == 0 ? argv[2] : argv[1]);
                return 1;
            }
            break;
        }
        in.k = (int64_t)vi[0];
        b.u = vi[1]; in.a_tip_meas = (float)b.d;
        b.u = vi[2]; in.a_frf_meas = (float)b.d;
        b.u = vi[3]; in.F_strain = (float)b.d;
        b.u = vi[4]; in.F_cell = (float)b.d;
        in.overran = vi[5] != 0;
        ctrl_step(&s, &in, &y);
        o[0] = y.v_tip_meas; o[1] = y.u_rel_hat; o[2] = y.v_rel_hat; o[3] = y.innovation; o[4] = y.f_r_hat;
        o[5] = y.F_set; o[6] = y.u0; o[7] = y.F_set_filtered; o[8] = y.V_cmd; o[9] = y.saturated;
        o[10] = y.fault_code; o[11] = y.fault_latched; o[12] = y.passive;
        for (j = 0; j < CTRL_N_OUTPUTS; ++j) {
            c.f = o[j];
            if ((uint64_t)c.u != vo[j]) {
                printf("FAIL tick %ld (k %lu) %s: ", ticks, (unsigned long)in.k, NAMES[j]);
                printf("%08lx", (unsigned long)c.u);
                printf(" expected ");
                printf("%08lx", (unsigned long)vo[j]);
                printf("\n");
                return 1;
            }
        }
        ++ticks;
    }
    if (ticks == 0) {
        printf("FAIL no ticks in %s\n", argv[1]);
        return 1;
    }
    printf("ok: %ld ticks x %d outputs bit-exact (float32), design %s\n", ticks, CTRL_N_OUTPUTS, ctrl_design_hash());
    return 0;
}
