/*
 * hal.h - the hardware layer the flight code runs on.
 *
 * Everything above this header (drivers, estimation, control, modes, the loop, telemetry) is
 * shared by every board. Two implementations:
 *
 *   hal/posix/    a Linux host: serial ports (termios), exactly as flightcode/ uses them.
 *                 The MCP3204 sits behind a Bus Pirate in binary SPI mode, the ESCs behind a
 *                 Pololu Maestro, the PPM train behind a timer-capture front-end that sends
 *                 6-byte capture records (docs/rc-capture-format.md).
 *   hal/lpc2148/  the NXP LPC2148 (UM10139): UART0 to the XSENS, UART1 to the XBee, SPI0 to
 *                 the MCP3204 with a GPIO chip select, a timer capture input for the PPM
 *                 train, four PWM outputs for the ESCs, interrupts through the VIC.
 *
 * Conventions
 *   - Times: uint64_t nanoseconds on one monotonic clock (hal_now_ns). Timeouts in ns.
 *   - No call blocks longer than the timeout it is given; calls without a timeout never block.
 *   - Return values: >= 0 a count or a result; < 0 a hal_status_t error.
 *   - The layer keeps no flight state: it moves bytes, SPI words, capture edges and pulse
 *     widths, and counts what went wrong on its own wires (hal_counters).
 *   - Single-threaded: the flight code calls the layer from one thread (the main loop);
 *     lpc2148 interrupt handlers share state with it only through the layer's ring buffers.
 */
#ifndef FW_HAL_H
#define FW_HAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* -- status -------------------------------------------------------------------------------- */

typedef enum {
    HAL_OK = 0,
    HAL_ERR_IO = -1,      /* the port or peripheral failed (unplugged, I/O error) */
    HAL_ERR_ABSENT = -2,  /* this board has no such device (e.g. SBUS on the lpc2148) */
    HAL_ERR_CONFIG = -3,  /* a configuration the layer cannot apply (baud, path) */
    HAL_ERR_DEVICE = -4   /* the device did not answer at bring-up (hal_last_error says how) */
} hal_status_t;

/* The devices, by the names the config file, the logs and the exit messages use. */
typedef enum {
    HAL_DEV_IMU = 0,       /* XSENS MTi, Xbus over a UART */
    HAL_DEV_ADC = 1,       /* MCP3204 on SPI */
    HAL_DEV_RC = 2,        /* PPM capture, or SBUS over a UART */
    HAL_DEV_ESC = 3,       /* four ESC pulse outputs */
    HAL_DEV_TELEMETRY = 4, /* XBee, API frames over a UART */
    HAL_DEV_COUNT = 5
} hal_dev_t;

/* "imu", "adc", "rc", "esc", "telemetry" */
const char *hal_dev_name(hal_dev_t dev);

/* -- configuration, given once to hal_open ------------------------------------------------ */

typedef enum {
    HAL_RC_CAPTURE = 0, /* PPM edges from a timer capture unit */
    HAL_RC_SBUS = 1     /* SBUS frames, 100000 8E2, on a UART */
} hal_rc_frontend_t;

typedef struct {
    const char *path; /* posix: device path; lpc2148: ignored (the pins are fixed) */
    uint32_t baud;    /* line rate, bit/s (SBUS: 100000) */
    bool enabled;     /* false: not opened (telemetry off) */
} hal_port_config_t;

typedef struct {
    hal_port_config_t port[HAL_DEV_COUNT];
    hal_rc_frontend_t rc_frontend;
    /* SPI to the MCP3204 */
    uint32_t spi_speed_hz;         /* posix: one of the Bus Pirate's speeds; lpc2148: SPI0 clock */
    uint64_t adc_read_timeout_ns;  /* longest wait for one sample's SPI reply (posix) */
    uint64_t adc_reply_timeout_ns; /* bridge entry: wait per reply; rest of a late reply (posix) */
    uint64_t adc_quiet_ns;         /* bridge entry: line quiet this long after the zeros (posix) */
    uint64_t adc_resync_interval_ns; /* after a failed re-entry, the next this much later
                                        (sensor time, the t_ns of hal_spi_exchange) (posix) */
    uint32_t adc_entry_attempts;   /* bridge entries tried at boot (posix) */
    /* ESC outputs */
    uint8_t esc_first_channel;     /* posix: Maestro channel of motor 0; lpc2148: ignored */
} hal_config_t;

/*
 * Open and set up every enabled device's port or peripheral (not the devices themselves:
 * the drivers bring those up). On failure returns < 0, sets *failed to the device and
 * hal_last_error() says why ("cannot open /dev/ttyS1: No such file or directory").
 */
int hal_open(const hal_config_t *cfg, hal_dev_t *failed);

/* Close everything hal_open opened (safe to call twice, or after a failed open). */
void hal_close(void);

/* The reason of the last failure of hal_open, hal_spi_start or an I/O error (static text). */
const char *hal_last_error(void);

/* -- time ----------------------------------------------------------------------------------- */

/* Monotonic time, ns. posix: CLOCK_MONOTONIC (virtual time under the bench's clock shim);
 * lpc2148: a free-running timer. Used for boot timeouts, the ADC reply waits and the
 * compute-time measurement; the flight code's own clock is the IMU's sample time. */
uint64_t hal_now_ns(void);

/* Wait ns (a port error in the loop keeps the watchdog's period instead of spinning). */
void hal_sleep_ns(uint64_t ns);

/* -- byte streams: the IMU, the telemetry modem and (SBUS) the RC receiver ---------------- */

typedef enum {
    HAL_UART_IMU = 0,       /* lpc2148: UART0 */
    HAL_UART_TELEMETRY = 1, /* lpc2148: UART1 */
    HAL_UART_RC = 2,        /* SBUS only; absent on the lpc2148 (both UARTs are taken) */
    HAL_UART_COUNT = 3
} hal_uart_t;

/* Read up to max bytes. Waits at most timeout_ns for the first byte, then returns what has
 * arrived without waiting further. Returns the count (0: nothing within the timeout) or < 0.
 * timeout_ns = 0 never waits. */
int32_t hal_uart_read(hal_uart_t uart, uint8_t *buf, size_t max, uint64_t timeout_ns);

/* Queue n bytes without blocking; returns how many were taken (fewer: the queue is full) or < 0. */
int32_t hal_uart_write(hal_uart_t uart, const uint8_t *data, size_t n);

/* Bytes received and not yet read / written and not yet sent; < 0 on error. */
int32_t hal_uart_in_waiting(hal_uart_t uart);
int32_t hal_uart_out_waiting(hal_uart_t uart);

/* Discard everything received and not yet read. */
void hal_uart_flush_input(hal_uart_t uart);

/* -- SPI to the MCP3204 --------------------------------------------------------------------- */

/* Boot: bring the SPI path up. posix: enter the Bus Pirate's binary SPI mode (blocks, with
 * adc_entry_attempts tries; HAL_ERR_DEVICE with hal_last_error() naming what came back);
 * lpc2148: SPI0 as master, mode 0, chip select high. */
int hal_spi_start(void);

typedef enum {
    HAL_SPI_DONE = 0,   /* every transfer's MISO bytes are in miso */
    HAL_SPI_BUSY = 1,   /* no request went out this sample (posix: a late reply still owed,
                           or the bridge is re-entering; lpc2148: never) */
    HAL_SPI_FAILED = 2  /* a request went out and gave no good reply this sample */
} hal_spi_result_t;

/*
 * One sample's conversions: n_transfers chip-select-framed transfers, transfer i of
 * lengths[i] bytes (1..16), MOSI bytes back to back in mosi, MISO bytes written back to back
 * into miso. t_ns is the sample's sensor time (paces the posix bridge's re-entries).
 * Returns a hal_spi_result_t (never blocks longer than adc_read_timeout_ns), or < 0.
 */
int hal_spi_exchange(const uint8_t *mosi, uint8_t *miso, const uint8_t *lengths, size_t n_transfers,
                     uint64_t t_ns);

/* The last DONE exchange's data were wrong (an MCP3204 null bit): set the SPI path up again.
 * posix: re-enter the Bus Pirate's SPI mode (non-blocking, over the next samples). */
void hal_spi_resync(void);

/* -- RC: PPM edges from a timer capture ----------------------------------------------------- */

/* One captured edge of the PPM line. */
typedef struct {
    uint16_t t_us;   /* capture timer at the edge, 1 us per count, wraps at 65536 */
    uint8_t seq;     /* +1 per edge recorded, wraps: a gap means edges were lost on the way */
    uint8_t level;   /* pin level after the edge (1: rising) */
    bool overrun;    /* at least one edge was lost just before this one */
} hal_edge_t;

/* Edges captured since the last call, oldest first, at most max; never blocks. Returns the
 * count or < 0 (HAL_ERR_ABSENT with the SBUS front-end). */
int32_t hal_rc_edges(hal_edge_t *out, size_t max);

/* -- ESC outputs ---------------------------------------------------------------------------- */

#define HAL_N_MOTORS 4

/* The four motors' pulse widths in quarter-microseconds (Maestro units; 4000 = 1000 us),
 * motor 0..3 as the mixer numbers them. posix: one Maestro Set Multiple Targets; lpc2148:
 * the PWM match registers, latched at the next period. Never blocks. */
int hal_esc_write(const uint16_t pulse_qus[HAL_N_MOTORS]);

/* -- counters of the layer's own wires ------------------------------------------------------- */

typedef struct {
    /* SPI / Bus Pirate (posix) */
    uint32_t adc_requests;        /* exchanges that sent a request */
    uint32_t adc_late_replies;    /* replies that missed the read timeout (collected later) */
    uint32_t adc_bad_replies;     /* replies of the wrong shape (short, bad ack) */
    uint32_t adc_short_writes;    /* requests the port took only in part */
    uint32_t adc_resyncs;         /* in-flight re-entries started */
    uint32_t adc_resync_failures; /* re-entries that failed */
    /* RC capture path: records with a bad CRC, bad flags, garbage bytes (posix), edges lost
     * to a full ring (lpc2148) */
    uint32_t rc_wire_errors;
    /* UART receive overruns, per hal_uart_t (lpc2148: LSR.OE; posix: 0) */
    uint32_t uart_overruns[HAL_UART_COUNT];
    /* writes the ESC port took only in part (posix) */
    uint32_t esc_short_writes;
} hal_counters_t;

const hal_counters_t *hal_counters(void);

/* -- log output and stop requests ------------------------------------------------------------ */

/* One log line (no newline at the end; the layer adds it). posix: stderr; lpc2148:
 * semihosting or a spare UART. Never blocks the loop for long; may drop when full. */
void hal_log_line(const char *line, size_t n);

/* True once the process was asked to stop (posix: SIGTERM or SIGINT; lpc2148: never).
 * hal_stop_signal() names the signal ("SIGTERM"), or "" when none. */
bool hal_stop_requested(void);
const char *hal_stop_signal(void);

#ifdef __cplusplus
}
#endif

#endif /* FW_HAL_H */
