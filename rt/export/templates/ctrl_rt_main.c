/*
 * ctrl_rt_main.c: an example main for a Linux PREEMPT_RT computer: the exported controller at
 * CTRL_RATE_HZ on absolute deadlines. A starting point for a rig, not a finished driver: the ADC
 * and the DAC are stubs (adc_read, dac_write) to replace with the rig's I/O.
 *
 *   make rt_example && sudo ./ctrl_rt_main [SECONDS] [PRIORITY]
 *
 * The pattern (docs/loop.md, as ros2_control and cyclictest do it):
 *   - mlockall(MCL_CURRENT | MCL_FUTURE): no page fault in the loop; the stack is touched first;
 *   - SCHED_FIFO at PRIORITY (default 80) for the calling thread; without the right (not root,
 *     no CAP_SYS_NICE) it says so and runs at normal priority;
 *   - clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME) to deadline next += period (never drifts);
 *     a tick that starts after its deadline sets the next tick's overrun flag, and the missed
 *     periods are skipped whole (the loop's pacing, rt/loop/pacing.py);
 *   - ctrl_init's guards first: a build that would not compute the design's bits does not run.
 * Exits 0 after SECONDS (default 1), printing the ticks run and overruns.
 */
#define _GNU_SOURCE   /* clock_nanosleep, sched_setscheduler, mlockall */
#include <errno.h>
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>

#include "frictionrt_ctrl.h"

#define NSEC_PER_SEC 1000000000LL

/* ---- the rig's I/O: replace these stubs ------------------------------------------------------- */

/* The four ADC readings of tick k in SI units (m/s^2, m/s^2, N, N). Stub: the state at rest. */
static void adc_read(int64_t k, ctrl_inputs *in)
{
    (void)k;
    in->a_tip_meas = 0.0;
    in->a_frf_meas = 0.0;
    in->F_strain = 200.0;
    in->F_cell = 200.0;
}

/* The commanded piezo voltage [V] to the DAC. Stub: nothing. */
static void dac_write(double V_cmd)
{
    (void)V_cmd;
}

/* ---- the loop ------------------------------------------------------------------------------------ */

static void add_ns(struct timespec *t, int64_t ns)
{
    int64_t s = (int64_t)t->tv_nsec + ns;
    t->tv_sec += (time_t)(s / NSEC_PER_SEC);
    t->tv_nsec = (long)(s % NSEC_PER_SEC);
}

static int64_t diff_ns(const struct timespec *a, const struct timespec *b)   /* a - b */
{
    return (int64_t)(a->tv_sec - b->tv_sec) * NSEC_PER_SEC + (int64_t)(a->tv_nsec - b->tv_nsec);
}

static void prefault_stack(void)
{
    volatile unsigned char buf[64 * 1024];
    memset((void *)buf, 0, sizeof buf);
}

int main(int argc, char **argv)
{
    const double seconds = argc > 1 ? atof(argv[1]) : 1.0;
    const int priority = argc > 2 ? atoi(argv[2]) : 80;
    const int64_t period_ns = (int64_t)(1e9 / CTRL_RATE_HZ + 0.5);
    const int64_t n_ticks = (int64_t)(seconds * CTRL_RATE_HZ);
    struct sched_param sp;
    struct timespec next, now;
    ctrl_state s;
    ctrl_inputs in;
    ctrl_outputs out;
    int64_t k = 0, overruns = 0;
    int overran = 0, rc;

    rc = ctrl_init(&s);
    if (rc != CTRL_OK) {
        fprintf(stderr, "ctrl_rt_main: ctrl_init: %s\n", ctrl_error_text(rc));
        return 1;
    }
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0)
        fprintf(stderr, "ctrl_rt_main: mlockall: %s (page faults possible)\n", strerror(errno));
    prefault_stack();
    memset(&sp, 0, sizeof sp);
    sp.sched_priority = priority;
    if (sched_setscheduler(0, SCHED_FIFO, &sp) != 0)
        fprintf(stderr, "ctrl_rt_main: SCHED_FIFO %d: %s (running at normal priority)\n", priority, strerror(errno));
    memset(&in, 0, sizeof in);
    in.faults = NULL;
    in.n_faults = 0;

    clock_gettime(CLOCK_MONOTONIC, &next);
    add_ns(&next, period_ns);
    while (k < n_ticks) {
        int64_t late;
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &next, NULL) == EINTR)
            ;
        in.k = k;
        in.overran = overran;
        adc_read(k, &in);
        ctrl_step(&s, &in, &out);
        dac_write(out.V_cmd);
        ++k;
        add_ns(&next, period_ns);
        clock_gettime(CLOCK_MONOTONIC, &now);
        late = diff_ns(&now, &next);
        overran = late > 0;
        if (overran) {                       /* skip the missed periods whole */
            const int64_t missed = late / period_ns + 1;
            overruns += 1;
            add_ns(&next, missed * period_ns);
            k += missed;
        }
    }
    printf("ctrl_rt_main: %lld ticks at %.0f Hz, %lld overruns, design %s\n", (long long)k, CTRL_RATE_HZ,
           (long long)overruns, ctrl_design_hash());
    return 0;
}
