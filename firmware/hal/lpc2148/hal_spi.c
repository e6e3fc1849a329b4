/*
 * hal_spi.c - SPI0 as master to the MCP3204 (UM10139 chapter 12), with the chip select on
 * GPIO P0.20: mode 0 (CPOL = 0, CPHA = 0), 8-bit transfers, the clock PCLK / S0SPCCR at or
 * below the configured rate. Each byte is written to S0SPDR and its answer read once SPIF (or
 * an error flag) sets: at 1 MHz a byte takes 8 us, an interrupt per byte would cost more than
 * the wait.
 */
#include "hal.h"
#include "lpc2148.h"
#include "lpc_internal.h"

#define CS_PIN (1u << 20)

static uint32_t g_spccr = 0;

static uint32_t spccr_for(uint32_t speed_hz)
{
    uint32_t div = speed_hz ? (PCLK_HZ + speed_hz - 1u) / speed_hz : 254u;
    div += div & 1u; /* even */
    if (div < 8u)
        div = 8u;
    if (div > 254u)
        div = 254u;
    return div;
}

static uint32_t g_speed_hz = 1000000u;

int hal_spi_start(void)
{
    PINSEL0 = (PINSEL0 & ~0x3F00u) | 0x1500u; /* P0.4 SCK0, P0.5 MISO0, P0.6 MOSI0 */
    PINSEL1 &= ~(3u << 8);                    /* P0.20: GPIO */
    IO0SET = CS_PIN;
    IO0DIR |= CS_PIN;
    g_spccr = spccr_for(g_speed_hz);
    S0SPCCR = g_spccr;
    S0SPCR = SPCR_MSTR;
    return HAL_OK;
}

/* hal_open's configuration of the clock (hal_spi_start applies it) */
void lpc_spi_config(uint32_t speed_hz) { g_speed_hz = speed_hz; }

static int xfer(uint8_t out, uint8_t *in)
{
    uint32_t sr;
    S0SPDR = out;
    while (!((sr = S0SPSR) & (SPSR_SPIF | SPSR_ERRORS))) {
    }
    if (sr & SPSR_ERRORS)
        return -1;
    *in = (uint8_t)S0SPDR;
    return 0;
}

int hal_spi_exchange(const uint8_t *mosi, uint8_t *miso, const uint8_t *lengths, size_t n_transfers, uint64_t t_ns)
{
    (void)t_ns;
    if (g_spccr == 0)
        return HAL_ERR_IO;
    lpc_counters.adc_requests++;
    size_t k = 0;
    for (size_t t = 0; t < n_transfers; t++) {
        IO0CLR = CS_PIN;
        for (uint32_t i = 0; i < lengths[t]; i++, k++) {
            if (xfer(mosi[k], &miso[k]) < 0) {
                IO0SET = CS_PIN;
                lpc_counters.adc_bad_replies++;
                S0SPCR = SPCR_MSTR; /* clears MODF after the status read */
                return HAL_SPI_FAILED;
            }
        }
        IO0SET = CS_PIN;
    }
    return HAL_SPI_DONE;
}

void hal_spi_resync(void)
{
    /* nothing to re-enter on a direct SPI: set the peripheral up again */
    S0SPCCR = g_spccr;
    S0SPCR = SPCR_MSTR;
}
