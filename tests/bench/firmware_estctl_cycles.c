/*
 * firmware_estctl_cycles.c - the firmware's estimation and control calls between markers, for
 * tests/bench/bench_firmware_estctl_cycles.py (run on the emulated LPC2148, MAM fully on).
 * Every module's state is warmed first (full flat-line window, a settled filter).
 */
#include <stdint.h>
#include "fc_design.h"
#include "estimation/altitude_kf.h"
#include "estimation/plausibility.h"
#include "estimation/baro_motion.h"
#include "control/reference.h"
#include "control/memory_attitude.h"
#include "control/yaw_rate.h"
#include "control/lqi_altitude.h"
#include "control/mixer.h"
#include "control/landing.h"

#define MARK(n) __attribute__((noinline)) void mark_##n(void) { __asm__ volatile("" ::: "memory"); }
MARK(0) MARK(1) MARK(2) MARK(3) MARK(4) MARK(5) MARK(6) MARK(7) MARK(8) MARK(9) MARK(10) MARK(11) MARK(12)

static altitude_kf_t kf;
static plausibility_t pl;
static baro_motion_t bm;
static prefilter3_t pf;
static memory_attitude_t mem;
static yaw_rate_t yaw;
static lqi_altitude_t lqi;
static mixer_t mx;
volatile float sink;

void bench(void)
{
    *(volatile uint32_t *)0xE01FC000u = 0u; /* MAMCR off */
    *(volatile uint32_t *)0xE01FC004u = 3u; /* MAMTIM 3 */
    *(volatile uint32_t *)0xE01FC000u = 2u; /* MAMCR fully on */
    altitude_kf_params_t kp = {&FC_DESIGN_KF_MODEL, 0.33f, 0.091f, 0.0025f, 25.0f, 400u};
    altitude_kf_init(&kf, &kp);
    plausibility_params_t pp = {60.0f, 40u, 1.5f, 5.0f, 3.0f};
    plausibility_init(&pl, &pp);
    baro_motion_params_t bp;
    baro_motion_params_make(&bp, 1500000000, 250000000, 1.5f);
    baro_motion_init(&bm, &bp);
    prefilter3_params_t pfp;
    prefilter3_params_make(&pfp, 8.0f, 0.0025f);
    prefilter3_init(&pf, &pfp);
    memory_attitude_gains_t g;
    memory_attitude_gains_from_poles(&g, 0.0025f, 5.0f, 15.0f, 4.0f, 0.015f, 0.005f, 0.8f);
    memory_attitude_init(&mem, &g);
    yaw_rate_params_t yp = {0.15f, 0.15f, 0.15f, 0.0025f};
    yaw_rate_init(&yaw, &yp);
    lqi_altitude_params_t lp;
    lqi_altitude_params_make(&lp, &FC_DESIGN_LQI_GAINS, 0.0025f, 1.1f, 20.6f);
    lqi_altitude_init(&lqi, &lp);
    mixer_params_t mp = {MIXER_FRAME_X, 0.25f, 5.15f, 0.016f, MIXER_DIFF_THROTTLE, 0.724f};
    mixer_init(&mx, &mp);
    float p = 101325.0f;
    for (int k = 0; k < 60; k++) { /* warm: full windows */
        altitude_kf_predict(&kf, 0.01f);
        altitude_kf_update(&kf, true, 0.1f, true, 0.2f, 1.0f);
        plausibility_baro_Pa(&pl, true, p + (float)(k % 7));
    }
    ref_state_t r = prefilter3_update(&pf, 0.1f);
    mixer_out_t out;
    float tau[3] = {0.05f, -0.03f, 0.01f};
    mark_0();
    altitude_kf_predict(&kf, 0.01f);
    mark_1();
    altitude_kf_update(&kf, true, 0.12f, true, 0.21f, 1.0f);
    mark_2();
    altitude_kf_update_at_rest(&kf);
    mark_3();
    sink = (float)plausibility_baro_Pa(&pl, true, p + 3.0f);
    mark_4();
    sink = (float)baro_motion_add(&bm, 2500000, true, 1.0f, true, 0.1f, 1.0f, 0.0f, true);
    mark_5();
    r = prefilter3_update(&pf, 0.1f);
    mark_6();
    sink = memory_attitude_update(&mem, &r, 0.01f, 0.02f, true);
    mark_7();
    sink = yaw_rate_update(&yaw, 0.1f, 0.05f, true);
    mark_8();
    sink = lqi_altitude_update(&lqi, 2.0f, 1.9f, 0.1f, 0.05f, true);
    mark_9();
    mixer_mix(&mx, 0.72f, tau, &out);
    mark_10();
    tau[0] = 2.0f;
    mixer_mix(&mx, 0.95f, tau, &out); /* saturated */
    mark_11();
    for (;;) {}
}

__attribute__((naked, section(".text.start"))) void _start(void)
{
    __asm__ volatile("ldr sp, =0x40007f00\n bl bench\n 1: b 1b\n");
}
