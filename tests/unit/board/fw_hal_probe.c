/*
 * A test program for the lpc2148 hardware layer on the emulated board
 * (tests/unit/board/test_lpc2148_hal.py): built with firmware/hal/lpc2148's startup, linker
 * script and layer, it exercises each device path and says what it saw on the console.
 *
 *   boot       -> "main" on the console, then hal_open
 *   ESC        -> hal_esc_write(4000, 5000, 6000, 8000)
 *   SPI        -> one exchange of two 3-byte transfers; "spi <6 MISO bytes hex>"
 *   loop       -> bytes from UART0 (50 ms timeout) are echoed to UART1 with "echo <n>";
 *                 PPM edges as "edge <t_us> <seq> <level> <overrun>"; "idle" after a timeout;
 *                 after 3 timeouts "done" and main returns (semihosting SYS_EXIT)
 */
#include <stdio.h>
#include <string.h>

#include "hal.h"

static void say(const char *text) { hal_log_line(text, strlen(text)); }

int main(void)
{
    char line[96];
    say("main");
    hal_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.port[HAL_DEV_IMU] = (hal_port_config_t){NULL, 921600, true};
    cfg.port[HAL_DEV_TELEMETRY] = (hal_port_config_t){NULL, 115200, true};
    cfg.port[HAL_DEV_RC] = (hal_port_config_t){NULL, 0, true};
    cfg.port[HAL_DEV_ESC] = (hal_port_config_t){NULL, 0, true};
    cfg.port[HAL_DEV_ADC] = (hal_port_config_t){NULL, 0, true};
    cfg.rc_frontend = HAL_RC_CAPTURE;
    cfg.spi_speed_hz = 1000000;
    hal_dev_t failed;
    if (hal_open(&cfg, &failed) < 0) {
        snprintf(line, sizeof line, "open failed %s: %s", hal_dev_name(failed), hal_last_error());
        say(line);
        return 3;
    }
    say("open");
    const uint16_t esc[HAL_N_MOTORS] = {4000, 5000, 6000, 8000};
    hal_esc_write(esc);

    if (hal_spi_start() < 0)
        say("spi start failed");
    const uint8_t mosi[6] = {0x06, 0x00, 0x00, 0x06, 0x40, 0x00};
    const uint8_t lengths[2] = {3, 3};
    uint8_t miso[6] = {0};
    int r = hal_spi_exchange(mosi, miso, lengths, 2, 0);
    snprintf(line, sizeof line, "spi %d %02x%02x%02x%02x%02x%02x", r, miso[0], miso[1], miso[2], miso[3], miso[4],
             miso[5]);
    say(line);

    int idle = 0;
    uint8_t buf[128];
    while (idle < 3) {
        int32_t n = hal_uart_read(HAL_UART_IMU, buf, sizeof buf, 50000000u);
        if (n > 0) {
            hal_uart_write(HAL_UART_TELEMETRY, buf, (size_t)n);
            snprintf(line, sizeof line, "echo %d", (int)n);
            say(line);
        } else {
            snprintf(line, sizeof line, "idle %lu", (unsigned long)(hal_now_ns() / 1000000u));
            say(line);
            idle++;
        }
        hal_edge_t edges[16];
        int32_t m = hal_rc_edges(edges, 16);
        for (int32_t i = 0; i < m; i++) {
            snprintf(line, sizeof line, "edge %u %u %u %u", edges[i].t_us, edges[i].seq, edges[i].level,
                     edges[i].overrun);
            say(line);
        }
    }
    snprintf(line, sizeof line, "done overruns %lu", (unsigned long)hal_counters()->uart_overruns[HAL_UART_IMU]);
    say(line);
    return 0;
}
