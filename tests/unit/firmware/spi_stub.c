/* What mcp3204.c needs of a hardware layer, for the tests: hal_spi_exchange answers with the
 * bytes the test put in spi_stub_reply (and keeps what it was sent), hal_spi_resync counts. */
#include <string.h>

#include "hal.h"

uint8_t spi_stub_reply[64];
uint8_t spi_stub_sent[64];
int spi_stub_resyncs;

int hal_spi_exchange(const uint8_t *mosi, uint8_t *miso, const uint8_t *lengths, size_t n_transfers, uint64_t t_ns)
{
    (void)t_ns;
    size_t n = 0;
    for (size_t i = 0; i < n_transfers; i++)
        n += lengths[i];
    memcpy(spi_stub_sent, mosi, n);
    memcpy(miso, spi_stub_reply, n);
    return HAL_SPI_DONE;
}

void hal_spi_resync(void) { spi_stub_resyncs++; }
