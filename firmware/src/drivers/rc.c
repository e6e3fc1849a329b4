/* RC input: see rc.h. */
#include "drivers/rc.h"

#include <string.h>

#include "hal.h"

void rc_init_capture(rc_input_t *rc, const ppm_params_t *params)
{
    memset(rc, 0, sizeof *rc);
    ppm_init(&rc->ppm, params);
    rc->stale_ns = (int64_t)(params->stale_ms * 1e6f);
}

void rc_init_sbus(rc_input_t *rc, float scale_us, float offset_us)
{
    memset(rc, 0, sizeof *rc);
    rc->sbus = true;
    sbus_parser_init(&rc->sbus_parser);
    rc->sbus_scale_us = scale_us;
    rc->sbus_offset_us = offset_us;
}

typedef struct {
    rc_input_t *rc;
    bool got;
    rc_frame_t frame;
} sbus_ctx_t;

static void on_sbus(void *ctx, const sbus_frame_t *f)
{
    sbus_ctx_t *c = ctx;
    if (f->flags & SBUS_FLAG_FRAME_LOST)
        c->rc->sbus_frame_lost_flags++;
    if (f->flags & SBUS_FLAG_FAILSAFE) {
        c->rc->sbus_failsafe_frames++;
        return;
    }
    c->got = true;
    c->frame.n = SBUS_N_CHANNELS;
    for (int i = 0; i < SBUS_N_CHANNELS; i++)
        c->frame.channels_us[i] = (float)f->raw[i] * c->rc->sbus_scale_us + c->rc->sbus_offset_us;
}

static int poll_sbus(rc_input_t *rc, int64_t t_ns)
{
    uint8_t rx[128];
    sbus_ctx_t ctx;
    int32_t waiting = hal_uart_in_waiting(HAL_UART_RC);
    memset(&ctx, 0, sizeof ctx);
    ctx.rc = rc;
    if (waiting <= 0)
        return waiting;
    while (waiting > 0) {
        int32_t got = hal_uart_read(HAL_UART_RC, rx, (size_t)waiting < sizeof rx ? (size_t)waiting : sizeof rx, 0);
        if (got <= 0)
            break;
        sbus_parser_feed(&rc->sbus_parser, rx, (size_t)got, on_sbus, &ctx);
        waiting -= got;
    }
    if (!ctx.got)
        return 0;
    rc->sbus_frames++;
    ctx.frame.valid = true;
    ctx.frame.t_ns = t_ns;
    rc->latest = ctx.frame;
    return 1;
}

static int poll_capture(rc_input_t *rc, int64_t t_ns)
{
    hal_edge_t edges[32];
    uint16_t widths[PPM_MAX_CHANNELS];
    bool fresh = false;
    bool first = true;
    for (;;) {
        int32_t n = hal_rc_edges(edges, sizeof edges / sizeof edges[0]);
        if (n < 0)
            return n;
        if (n == 0)
            break;
        if (first) {
            if (rc->have_rx && t_ns - rc->last_rx_ns > rc->stale_ns) {
                /* a 16-bit capture difference across a long silence is aliased */
                ppm_desync(&rc->ppm);
                rc->ppm.counters.stale_restarts++;
            }
            rc->have_rx = true;
            rc->last_rx_ns = t_ns;
            first = false;
        }
        for (int32_t i = 0; i < n; i++) {
            int count = ppm_edge(&rc->ppm, &edges[i], widths);
            if (count > 0) {
                rc->latest.valid = true;
                rc->latest.t_ns = t_ns;
                rc->latest.n = (uint8_t)count;
                for (int k = 0; k < count; k++)
                    rc->latest.channels_us[k] = (float)widths[k];
                fresh = true;
            }
        }
        if ((size_t)n < sizeof edges / sizeof edges[0])
            break;
    }
    return fresh ? 1 : 0;
}

int rc_poll(rc_input_t *rc, int64_t t_ns) { return rc->sbus ? poll_sbus(rc, t_ns) : poll_capture(rc, t_ns); }

uint32_t rc_errors(const rc_input_t *rc)
{
    uint32_t wire = hal_counters()->rc_wire_errors;
    if (rc->sbus)
        return rc->sbus_parser.counters.garbage_bytes + rc->sbus_failsafe_frames;
    return wire + rc->ppm.counters.sequence_gaps + rc->ppm.counters.overruns + rc->ppm.counters.missing_edges +
           rc->ppm.counters.bad_pulses;
}
