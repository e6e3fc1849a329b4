/*
 * The posix layer's devices behind its ports: the MCP3204's SPI through a Bus Pirate in
 * binary SPI mode (src/drivers/buspirate.c on the adc port), PPM capture edges from the
 * timer-capture front-end's records (src/drivers/ppm.c's record parser on the rc port), and
 * the ESC pulses as one Maestro Set Multiple Targets (src/drivers/maestro.c on the esc port).
 */
#include <string.h>

#include "drivers/buspirate.h"
#include "drivers/maestro.h"
#include "drivers/ppm.h"
#include "hal.h"
#include "posix_port.h"

static struct {
    bp_bridge_t bridge;
    capture_parser_t capture;
    bool sbus;
    uint8_t esc_first_channel;
    hal_counters_t counters;
} d;

static int32_t adc_read(void *ctx, uint8_t *buf, size_t max, uint64_t timeout_ns)
{
    (void)ctx;
    return posix_port_read(HAL_DEV_ADC, buf, max, timeout_ns);
}
static int32_t adc_write(void *ctx, const uint8_t *data, size_t n)
{
    (void)ctx;
    return posix_port_write(HAL_DEV_ADC, data, n);
}
static int32_t adc_in_waiting(void *ctx)
{
    (void)ctx;
    return posix_port_in_waiting(HAL_DEV_ADC);
}
static void adc_flush(void *ctx)
{
    (void)ctx;
    posix_port_flush_input(HAL_DEV_ADC);
}

int posix_devices_open(const hal_config_t *cfg)
{
    bp_port_t port = {NULL, adc_read, adc_write, adc_in_waiting, adc_flush, hal_now_ns};
    memset(&d, 0, sizeof d);
    bp_init(&d.bridge, &port, cfg->spi_speed_hz, cfg->adc_entry_attempts, cfg->adc_read_timeout_ns,
            cfg->adc_reply_timeout_ns, cfg->adc_quiet_ns, cfg->adc_resync_interval_ns);
    capture_parser_init(&d.capture);
    d.sbus = cfg->rc_frontend == HAL_RC_SBUS;
    d.esc_first_channel = cfg->esc_first_channel;
    return HAL_OK;
}

void posix_devices_close(void) {}

/* -- SPI ------------------------------------------------------------------------------------------ */

int hal_spi_start(void)
{
    static char why[200];
    if (posix_port_fd(HAL_DEV_ADC) < 0)
        return HAL_ERR_ABSENT;
    if (!bp_enter_spi(&d.bridge, why, sizeof why)) {
        posix_fail("%s", why);
        return HAL_ERR_DEVICE;
    }
    return HAL_OK;
}

int hal_spi_exchange(const uint8_t *mosi, uint8_t *miso, const uint8_t *lengths, size_t n_transfers, uint64_t t_ns)
{
    int r = bp_exchange(&d.bridge, mosi, lengths, n_transfers, miso, t_ns);
    if (r < 0)
        return r;
    return r == 0 ? HAL_SPI_DONE : r == 1 ? HAL_SPI_BUSY : HAL_SPI_FAILED;
}

void hal_spi_resync(void) { bp_lose_sync(&d.bridge, false); }

/* -- RC capture ----------------------------------------------------------------------------------- */

int32_t hal_rc_edges(hal_edge_t *out, size_t max)
{
    size_t got = 0;
    if (d.sbus || posix_port_fd(HAL_DEV_RC) < 0)
        return HAL_ERR_ABSENT;
    for (;;) {
        uint8_t rx[48];
        size_t room = sizeof d.capture.buf - d.capture.n;
        int32_t n;
        got += capture_parser_pop(&d.capture, out + got, max - got);
        if (got == max || room == 0)
            break;
        /* a non-blocking read straight away: one call whether or not records came */
        n = posix_port_read(HAL_DEV_RC, rx, room < sizeof rx ? room : sizeof rx, 0);
        if (n < 0)
            return n;
        if (n == 0)
            break;
        capture_parser_push(&d.capture, rx, (size_t)n);
    }
    return (int32_t)got;
}

/* -- ESC ---------------------------------------------------------------------------------------------- */

int hal_esc_write(const uint16_t pulse_qus[HAL_N_MOTORS])
{
    uint8_t frame[3 + 2 * HAL_N_MOTORS];
    size_t n = maestro_set_multiple_targets(d.esc_first_channel, pulse_qus, HAL_N_MOTORS, frame, sizeof frame);
    int32_t w;
    if (!n)
        return HAL_ERR_CONFIG;
    w = posix_port_write(HAL_DEV_ESC, frame, n);
    if (w < 0)
        return w;
    if ((size_t)w < n) /* the Maestro resynchronises on the next command byte (MSB set) */
        d.counters.esc_short_writes++;
    return HAL_OK;
}

/* -- counters ------------------------------------------------------------------------------------------- */

const hal_counters_t *hal_counters(void)
{
    const bp_counters_t *b = &d.bridge.counters;
    d.counters.adc_requests = b->requests;
    d.counters.adc_late_replies = b->late_replies;
    d.counters.adc_bad_replies = b->bad_ack + b->short_replies;
    d.counters.adc_short_writes = b->short_writes;
    d.counters.adc_resyncs = b->resyncs;
    d.counters.adc_resync_failures = b->resync_failures;
    d.counters.rc_wire_errors = d.capture.counters.crc_errors + d.capture.counters.bad_flags +
                                d.capture.counters.garbage_bytes;
    return &d.counters;
}

hal_counters_t *posix_counters(void) { return &d.counters; }
