/* XSENS MTi driver: see xsens.h. */
#include "drivers/xsens.h"

#include <stdio.h>
#include <string.h>

#include "drivers/imu_checks.h"
#include "hal.h"
#include "log.h"

#define DEG_F 0.017453292519943295f
#define RX_CHUNK 256

void xsens_init(xsens_t *x, const xsens_params_t *params)
{
    memset(x, 0, sizeof *x);
    x->params = *params;
    xbus_parser_init(&x->parser, XBUS_MAX_PAYLOAD);
    if (params->legacy) {
        x->period_ns = (int64_t)mtdata_legacy_period(params->rate_hz) * 1000000000LL / MTDATA_LEGACY_PERIOD_CLOCK_HZ;
        x->frame_len = 5 + mtdata_legacy_length(LEGACY_OUTPUT_MODE, LEGACY_OUTPUT_SETTINGS);
    } else {
        x->period_ns = 1000000000LL / params->rate_hz;
        x->frame_len = 5 + MTDATA_MK4_PAYLOAD_LEN;
    }
}

static const char *mid_name(uint8_t mid)
{
    switch (mid) {
    case XBUS_GOTO_CONFIG: return "goto_config";
    case XBUS_REQ_DID: return "req_did";
    case XBUS_REQ_PRODUCT_CODE: return "req_product_code";
    case XBUS_REQ_FW_REV: return "req_fw_rev";
    case XBUS_SET_OUTPUT_CONFIGURATION: return "set_output_configuration";
    case XBUS_SET_OUTPUT_MODE: return "set_output_mode";
    case XBUS_SET_OUTPUT_SETTINGS: return "set_output_settings";
    case XBUS_SET_PERIOD: return "set_period";
    case XBUS_GOTO_MEASUREMENT: return "goto_measurement";
    default: return "unknown";
    }
}

static const char *error_meaning(int code)
{
    switch (code) {
    case 0x03: return "period invalid";
    case 0x04: return "message invalid or not implemented";
    case 0x20: return "baud rate out of range";
    case 0x21: return "invalid parameter";
    case 0x35: return "output configuration error";
    default: return "unknown";
    }
}

/* -- measurement decoding (also used for samples that arrive with a boot ack) ------------- */

static bool decode(xsens_t *x, const xbus_msg_t *m, xsens_data_t *out)
{
    if (m->mid == XBUS_MT_DATA2 && !x->params.legacy)
        return mtdata_decode2(m->payload, m->len, out, &x->counters.mtdata);
    if (m->mid == XBUS_MT_DATA && x->params.legacy)
        return mtdata_decode_legacy(m->payload, m->len, LEGACY_OUTPUT_MODE, LEGACY_OUTPUT_SETTINGS, out,
                                    &x->counters.mtdata);
    x->counters.unexpected_messages++;
    return false;
}

/* A decoded sample replaces the pending one (which counts as skipped). */
static void keep_newest(xsens_t *x, const xbus_msg_t *m)
{
    xsens_data_t d;
    if (!decode(x, m, &d))
        return;
    if (x->pending)
        x->pending_skipped++;
    x->pending = true;
    x->pending_data = d;
}

/* -- boot ----------------------------------------------------------------------------------- */

typedef struct {
    xsens_t *x;
    uint8_t ack;
    bool found;     /* the ack (or an Error) arrived */
    bool error;     /* it was an Error message */
    int error_code;
    uint8_t payload[64];
    size_t len;
} transact_t;

static void on_boot_msg(void *ctx, const xbus_msg_t *m)
{
    transact_t *t = ctx;
    if (t->found) { /* what follows the ack is kept for the loop */
        keep_newest(t->x, m);
        return;
    }
    if (m->mid == t->ack) {
        t->found = true;
        t->len = m->len < sizeof t->payload ? m->len : sizeof t->payload;
        memcpy(t->payload, m->payload, t->len);
    } else if (m->mid == XBUS_ERROR) {
        t->found = true;
        t->error = true;
        t->error_code = m->len ? m->payload[0] : -1;
    }
}

/* Send mid until ack comes back: 1 with its payload in t, 0 an Error reply (logged), -1 no
 * answer within attempts x reply timeout (why says so). */
static int transact(xsens_t *x, uint8_t mid, const uint8_t *payload, size_t len, uint8_t ack, uint32_t attempts,
                    transact_t *t, char *why, size_t why_len)
{
    uint8_t frame[64];
    uint8_t rx[RX_CHUNK];
    size_t n = xbus_encode(mid, payload, len, frame, sizeof frame);
    memset(t, 0, sizeof *t);
    t->x = x;
    t->ack = ack;
    for (uint32_t a = 0; a < attempts; a++) {
        uint64_t deadline = hal_now_ns() + x->params.reply_timeout_ns;
        if (hal_uart_write(HAL_UART_IMU, frame, n) < 0) {
            snprintf(why, why_len, "cannot write %s: %s", mid_name(mid), hal_last_error());
            return -1;
        }
        for (;;) {
            uint64_t now = hal_now_ns();
            int32_t got;
            if (now >= deadline)
                break;
            got = hal_uart_read(HAL_UART_IMU, rx, sizeof rx, deadline - now);
            if (got < 0) {
                snprintf(why, why_len, "cannot read: %s", hal_last_error());
                return -1;
            }
            xbus_feed(&x->parser, rx, (size_t)got, on_boot_msg, t);
            if (t->found) {
                if (!t->error)
                    return 1;
                if (log_begin(LOG_WARNING, "imu.error_reply")) {
                    log_str("request", mid_name(mid));
                    log_int("code", t->error_code);
                    log_str("meaning", error_meaning(t->error_code));
                    log_end();
                }
                return 0;
            }
        }
    }
    snprintf(why, why_len, "no answer to %s (expected MID 0x%02x) after %lu attempt(s) of %g s", mid_name(mid), ack,
             (unsigned long)attempts, (double)x->params.reply_timeout_ns / 1e9);
    return -1;
}

static bool require(xsens_t *x, uint8_t mid, const uint8_t *payload, size_t len, uint8_t ack, transact_t *t,
                    char *why, size_t why_len)
{
    int r = transact(x, mid, payload, len, ack, 1, t, why, why_len);
    if (r == 0) {
        bool hint = mid == XBUS_SET_OUTPUT_CONFIGURATION || mid == XBUS_SET_OUTPUT_MODE;
        snprintf(why, why_len, "device refused %s with an Error message%s", mid_name(mid),
                 hint ? " (is imu.identity right?)" : "");
    }
    return r == 1;
}

static void hex_bytes(const uint8_t *b, size_t n, char *out, size_t cap)
{
    size_t k = 0;
    out[0] = '\0';
    for (size_t i = 0; i < n && k + 4 < cap; i++)
        k += (size_t)snprintf(out + k, cap - k, i ? " %02x" : "%02x", b[i]);
}

bool xsens_bring_up(xsens_t *x, xsens_info_t *info, char *why, size_t why_len)
{
    transact_t t;
    char id[12];
    memset(info, 0, sizeof *info);
    hal_uart_flush_input(HAL_UART_IMU);
    if (transact(x, XBUS_GOTO_CONFIG, NULL, 0, XBUS_GOTO_CONFIG_ACK, x->params.goto_config_attempts, &t, why,
                 why_len) < 0)
        return false;
    if (!require(x, XBUS_REQ_DID, NULL, 0, XBUS_DEVICE_ID, &t, why, why_len))
        return false;
    for (size_t i = 0; i < t.len && i < 4; i++)
        info->device_id = (info->device_id << 8) | t.payload[i];
    if (transact(x, XBUS_REQ_PRODUCT_CODE, NULL, 0, XBUS_PRODUCT_CODE, 1, &t, why, why_len) < 0)
        return false;
    if (!t.error) { /* the text up to the first space, NULs stripped */
        size_t k = 0;
        for (size_t i = 0; i < t.len && t.payload[i] != ' ' && k + 1 < sizeof info->product_code; i++)
            if (t.payload[i] != 0)
                info->product_code[k++] = (t.payload[i] < 0x80) ? (char)t.payload[i] : '?';
        info->product_code[k] = '\0';
    }
    if (transact(x, XBUS_REQ_FW_REV, NULL, 0, XBUS_FIRMWARE_REV, 1, &t, why, why_len) < 0)
        return false;
    if (!t.error && t.len >= 3)
        snprintf(info->firmware, sizeof info->firmware, "%u.%u.%u", t.payload[0], t.payload[1], t.payload[2]);
    snprintf(id, sizeof id, "%08lX", (unsigned long)info->device_id);
    if (log_begin(LOG_INFO, "imu.identified")) {
        log_str("device_id", id);
        log_str("product", info->product_code);
        log_str("firmware", info->firmware);
        log_str("identity", x->params.legacy ? "legacy" : "mk4");
        log_end();
    }
    if (x->params.legacy) {
        uint16_t period = mtdata_legacy_period(x->params.rate_hz);
        uint8_t mode[2] = {(uint8_t)(LEGACY_OUTPUT_MODE >> 8), (uint8_t)LEGACY_OUTPUT_MODE};
        uint32_t s = LEGACY_OUTPUT_SETTINGS;
        uint8_t settings[4] = {(uint8_t)(s >> 24), (uint8_t)(s >> 16), (uint8_t)(s >> 8), (uint8_t)s};
        uint8_t per[2] = {(uint8_t)(period >> 8), (uint8_t)period};
        if (!require(x, XBUS_SET_OUTPUT_MODE, mode, 2, XBUS_SET_OUTPUT_MODE_ACK, &t, why, why_len) ||
            !require(x, XBUS_SET_OUTPUT_SETTINGS, settings, 4, XBUS_SET_OUTPUT_SETTINGS_ACK, &t, why, why_len) ||
            !require(x, XBUS_SET_PERIOD, per, 2, XBUS_SET_PERIOD_ACK, &t, why, why_len))
            return false;
        if (log_begin(LOG_INFO, "imu.configured")) {
            log_str("output", "mtdata");
            log_int("period", period);
            log_int("rate_hz", x->params.rate_hz);
            log_end();
        }
    } else {
        uint8_t request[4 * MTDATA_MK4_ENTRIES];
        mtdata_mk4_output_configuration(x->params.rate_hz, request);
        if (!require(x, XBUS_SET_OUTPUT_CONFIGURATION, request, sizeof request, XBUS_SET_OUTPUT_CONFIGURATION_ACK, &t,
                     why, why_len))
            return false;
        if (t.len != sizeof request || memcmp(t.payload, request, sizeof request) != 0) {
            char got[100], want[100];
            hex_bytes(t.payload, t.len, got, sizeof got);
            hex_bytes(request, sizeof request, want, sizeof want);
            snprintf(why, why_len, "SetOutputConfiguration applied %s instead of %s", got, want);
            return false;
        }
        if (log_begin(LOG_INFO, "imu.configured")) {
            log_str("output", "mtdata2");
            log_int("rate_hz", x->params.rate_hz);
            log_end();
        }
    }
    return true;
}

bool xsens_start(xsens_t *x, char *why, size_t why_len)
{
    transact_t t;
    if (!require(x, XBUS_GOTO_MEASUREMENT, NULL, 0, XBUS_GOTO_MEASUREMENT_ACK, &t, why, why_len))
        return false;
    /* in measurement state only samples of the configured size are expected: a corrupted
     * length byte must not make the parser wait for kilobytes */
    xbus_parser_set_max_payload(&x->parser, (uint16_t)(x->frame_len - 5));
    return true;
}

/* -- measurement ---------------------------------------------------------------------------- */

static bool believable(xsens_t *x, const imu_sample_t *s)
{
    float dt_s = 0.0f;
    imu_verdict_t v;
    if (x->have_accepted && s->t_ns > x->accepted_t_ns)
        dt_s = (float)(s->t_ns - x->accepted_t_ns) * 1e-9f;
    v = imu_implausible(s->euler_rad, s->omega_B_radps, s->f_B_mps2, x->have_accepted ? x->accepted_euler : NULL,
                        x->have_accepted ? x->accepted_omega : NULL, dt_s);
    if (v != IMU_PLAUSIBLE) {
        x->value_rejects_in_row++;
        /* a value out of range is never true; a jump that persists is the vehicle's */
        if (!imu_verdict_is_jump(v) || x->value_rejects_in_row < XSENS_REBASE_AFTER_REJECTS) {
            x->counters.rejected_values++;
            return false;
        }
        x->counters.value_rebases++;
    }
    x->value_rejects_in_row = 0;
    x->have_accepted = true;
    x->accepted_t_ns = s->t_ns;
    memcpy(x->accepted_euler, s->euler_rad, sizeof x->accepted_euler);
    memcpy(x->accepted_omega, s->omega_B_radps, sizeof x->accepted_omega);
    return true;
}

bool xsens_to_sample(xsens_t *x, const xsens_data_t *d, uint32_t skipped, imu_sample_t *out)
{
    uint32_t raw, modulus_mask;
    int64_t tick_ns;
    bool have_step = x->have_counter;
    uint16_t step = (uint16_t)(d->counter - x->last_counter);
    if (x->params.legacy) {
        raw = d->counter;
        modulus_mask = 0xFFFFu;
        tick_ns = x->period_ns;
    } else {
        raw = d->sample_time_fine;
        modulus_mask = 0xFFFFFFFFu;
        tick_ns = 1000000000LL / MTDATA_SAMPLE_TIME_FINE_HZ;
    }
    if (!x->have_base) {
        x->have_base = true;
    } else {
        int64_t ticks = (int64_t)((raw - x->last_raw) & modulus_mask);
        if (!x->params.legacy && have_step) {
            int64_t period_ticks = MTDATA_SAMPLE_TIME_FINE_HZ / x->params.rate_hz;
            int64_t slip = ticks - (int64_t)step * period_ticks;
            if (slip < 0)
                slip = -slip;
            if (slip > XSENS_MAX_TIME_SLIP_PERIODS * period_ticks) {
                x->rejects_in_row++;
                if (x->rejects_in_row < XSENS_REBASE_AFTER_REJECTS) {
                    x->counters.rejected_time_jumps++;
                    return false;
                }
                x->counters.time_rebases++; /* the device's clock, as it says */
            }
        }
        x->clock_ticks += ticks;
    }
    x->rejects_in_row = 0;
    x->last_raw = raw;
    if (have_step && step != 1) {
        if (step) {
            x->counters.gap_samples += (uint32_t)(step - 1);
            x->counters.gaps++;
        } else {
            x->counters.duplicates++;
        }
    }
    x->have_counter = true;
    x->last_counter = d->counter;
    out->t_ns = x->clock_ticks * tick_ns;
    out->counter = d->counter;
    for (int i = 0; i < 3; i++) {
        out->euler_rad[i] = d->euler_deg[i] * DEG_F;
        out->omega_B_radps[i] = d->rate_of_turn_radps[i];
        out->f_B_mps2[i] = d->acceleration_mps2[i];
    }
    out->status = d->status;
    out->skipped = skipped;
    return believable(x, out);
}

static void on_sample_msg(void *ctx, const xbus_msg_t *m) { keep_newest((xsens_t *)ctx, m); }

/* The newest decoded sample (in x->pending): 1, 0 at the deadline, < 0 a port error. */
static int read_newest(xsens_t *x, uint64_t deadline, uint64_t timeout_ns)
{
    uint8_t rx[RX_CHUNK];
    for (;;) {
        int32_t got;
        if (!x->pending) {
            size_t want = xbus_bytes_needed(&x->parser, x->frame_len);
            got = hal_uart_read(HAL_UART_IMU, rx, want < sizeof rx ? want : sizeof rx, timeout_ns);
        } else {
            int32_t waiting = hal_uart_in_waiting(HAL_UART_IMU); /* anything newer queued? take it */
            if (waiting <= 0)
                break;
            got = hal_uart_read(HAL_UART_IMU, rx, (size_t)waiting < sizeof rx ? (size_t)waiting : sizeof rx, 0);
        }
        if (got < 0)
            return got;
        xbus_feed(&x->parser, rx, (size_t)got, on_sample_msg, x);
        if (!x->pending) {
            uint64_t now;
            if (got == 0)
                return 0; /* the read timed out in silence */
            now = hal_now_ns();
            /* past the deadline, finish only what is already queued; a babbling device
             * (bytes, never a valid sample) still trips the watchdog by the hard limit */
            if (now >= deadline && (now >= deadline + timeout_ns || hal_uart_in_waiting(HAL_UART_IMU) <= 0))
                return 0;
        }
    }
    return 1;
}

int xsens_read_sample(xsens_t *x, uint64_t timeout_ns, imu_sample_t *out)
{
    uint64_t deadline = hal_now_ns() + timeout_ns;
    for (;;) {
        int r = read_newest(x, deadline, timeout_ns);
        xsens_data_t d;
        uint32_t skipped;
        if (r <= 0)
            return r;
        d = x->pending_data;
        skipped = x->pending_skipped;
        x->pending = false;
        x->pending_skipped = 0;
        if (skipped)
            x->counters.skipped_samples += skipped;
        if (xsens_to_sample(x, &d, skipped, out))
            return 1;
    }
}
