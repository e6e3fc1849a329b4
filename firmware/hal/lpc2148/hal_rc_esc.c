/*
 * hal_rc_esc.c - the PPM receiver on a timer capture input and the four ESC outputs.
 *
 * PPM: CAP1.0 (P0.10) captures Timer1 (1 us per count) on both edges, with an interrupt; the
 * handler rings each edge (16-bit time, sequence number, the pin's level, a flag when the ring
 * was full and edges were lost).
 *
 * ESCs at ESC_RATE_HZ (a 2.5 ms period), widths in quarter-microseconds as hal.h gives them:
 *   ESC 0, 1: PWM2 (P0.7) and PWM5 (P0.21), single-edged, PWMMR0 the period; a width goes to
 *             the shadow match register and takes effect at the next period (PWMLER).
 *   ESC 2, 3: Timer1's match outputs MAT1.2 (P0.17) and MAT1.3 (P0.18), free-running: each
 *             match sets or clears its output in hardware (EMR), and the handler programs the
 *             next edge; a width takes effect at the next rising edge. 1 us resolution.
 * The outputs stay low until the first hal_esc_write.
 */
#include <string.h>

#include "hal.h"
#include "lpc2148.h"
#include "lpc_internal.h"

/* -- PPM capture ---------------------------------------------------------------------------- */

#define EDGES 64u /* power of two */
#define PPM_PIN (1u << 10)

static struct {
    hal_edge_t ring[EDGES];
    volatile uint16_t head, tail;
    uint8_t seq;
    bool lost;
    bool open;
} g_rc;

void lpc_rc_open(bool capture)
{
    g_rc.head = g_rc.tail = 0;
    g_rc.seq = 0;
    g_rc.lost = false;
    g_rc.open = capture;
    if (!capture)
        return;
    PINSEL0 = (PINSEL0 & ~(3u << 20)) | (2u << 20); /* P0.10: CAP1.0 */
    T1CCR = 0x7u;                                   /* CR0 on rising and falling edges, interrupt */
}

void lpc_capture_isr(void)
{
    uint32_t t = T1CR0;
    uint8_t level = (IO0PIN & PPM_PIN) ? 1u : 0u;
    uint16_t next = (uint16_t)((g_rc.head + 1u) & (EDGES - 1u));
    g_rc.seq++;
    if (next == g_rc.tail) {
        g_rc.lost = true;
        lpc_counters.rc_wire_errors++;
        return;
    }
    hal_edge_t *e = &g_rc.ring[g_rc.head];
    e->t_us = (uint16_t)t;
    e->seq = g_rc.seq;
    e->level = level;
    e->overrun = g_rc.lost;
    g_rc.lost = false;
    g_rc.head = next;
}

int32_t hal_rc_edges(hal_edge_t *out, size_t max)
{
    if (!g_rc.open)
        return HAL_ERR_ABSENT;
    uint32_t saved = irq_save();
    size_t n = 0;
    while (g_rc.tail != g_rc.head && n < max) {
        out[n++] = g_rc.ring[g_rc.tail];
        g_rc.tail = (uint16_t)((g_rc.tail + 1u) & (EDGES - 1u));
    }
    irq_restore(saved);
    return (int32_t)n;
}

/* -- ESC outputs ---------------------------------------------------------------------------- */

#define PWM_TICKS_PER_QUS (PCLK_HZ / 4000000u) /* 15 PCLK ticks per quarter-microsecond */
#define EMC_CLEAR 1u
#define EMC_SET 2u

typedef struct {
    volatile uint32_t width_us; /* taken at the next rising edge */
    uint32_t high_us;           /* the pulse being sent */
    bool high;
} mat_channel_t;

static struct {
    mat_channel_t mat[2]; /* MAT1.2, MAT1.3 */
    bool started;
    bool open;
} g_esc;

void lpc_esc_open(void)
{
    memset(&g_esc, 0, sizeof g_esc);
    g_esc.open = true;
    PINSEL0 = (PINSEL0 & ~(3u << 14)) | (2u << 14);                            /* P0.7: PWM2 */
    PINSEL1 = (PINSEL1 & ~((3u << 10) | (3u << 2) | (3u << 4))) | (1u << 10)   /* P0.21: PWM5 */
              | (3u << 2) | (3u << 4);                                         /* P0.17 MAT1.2, P0.18 MAT1.3 */
    PWMTCR = 2; /* counter reset while set up */
    PWMPR = 0;
    PWMMR0 = PCLK_HZ / ESC_RATE_HZ - 1u;
    PWMMCR = 1u << 1; /* reset on MR0 */
    PWMMR2 = 0;
    PWMMR5 = 0;
    PWMLER = (1u << 0) | (1u << 2) | (1u << 5);
    PWMPCR = 0; /* single-edged, outputs off until the first write */
    PWMTCR = 1u | 8u; /* counter and PWM mode on */
    T1EMR = 0;        /* MAT1.2, MAT1.3 low, no action on match */
}

/* Timer1 MR2/MR3: an ESC edge just happened in hardware; program the next one. */
void lpc_esc_timer_isr(uint32_t ir)
{
    if (!g_esc.started)
        return;
    for (uint32_t c = 0; c < 2; c++) {
        if (!(ir & (TIR_MR2 << c)))
            continue;
        mat_channel_t *m = &g_esc.mat[c];
        volatile uint32_t *mr = c ? &T1MR3 : &T1MR2;
        uint32_t shift = 4u + 2u * (2u + c);
        if (m->high) { /* the falling edge: the next rise one period after the last */
            *mr += ESC_PERIOD_US - m->high_us;
            T1EMR = (T1EMR & ~(3u << shift)) | (EMC_SET << shift);
            m->high = false;
        } else {       /* the rising edge: fall after the width */
            m->high_us = m->width_us;
            *mr += m->high_us;
            T1EMR = (T1EMR & ~(3u << shift)) | (EMC_CLEAR << shift);
            m->high = true;
        }
    }
}

static void esc_start(void)
{
    /* the first rising edges 100 us from now, both channels in phase */
    uint32_t first = T1TC + 100u;
    T1MR2 = first;
    T1MR3 = first;
    T1EMR = (EMC_SET << 8) | (EMC_SET << 10);
    PWMPCR = (1u << 10) | (1u << 13); /* PWMENA2, PWMENA5 */
    g_esc.started = true;
}

int hal_esc_write(const uint16_t pulse_qus[HAL_N_MOTORS])
{
    if (!g_esc.open)
        return HAL_ERR_IO;
    PWMMR2 = pulse_qus[0] * PWM_TICKS_PER_QUS;
    PWMMR5 = pulse_qus[1] * PWM_TICKS_PER_QUS;
    PWMLER = (1u << 2) | (1u << 5);
    g_esc.mat[0].width_us = (pulse_qus[2] + 2u) / 4u;
    g_esc.mat[1].width_us = (pulse_qus[3] + 2u) / 4u;
    if (!g_esc.started) {
        uint32_t saved = irq_save();
        esc_start();
        irq_restore(saved);
    }
    return HAL_OK;
}
