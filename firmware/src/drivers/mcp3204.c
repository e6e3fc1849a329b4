/* MCP3204 reads: see mcp3204.h. */
#include "drivers/mcp3204.h"

#include "hal.h"

#define START_BIT 0x40u
#define SINGLE_ENDED 0x20u

void mcp3204_request(uint8_t channel, uint8_t out[MCP3204_FRAME])
{
    out[0] = (uint8_t)(START_BIT | SINGLE_ENDED | ((channel & 0x3u) << 2));
    out[1] = 0x00;
    out[2] = 0x00;
    out[3] = 0x00;
}

int mcp3204_decode(const uint8_t miso[MCP3204_FRAME])
{
    if (miso[0] & MCP3204_NULL_BIT)
        return -1;
    return (miso[1] << 4) | (miso[2] >> 4);
}

bool mcp3204_repeat_agrees(const uint8_t miso[MCP3204_FRAME], int code)
{
    uint32_t repeat = ((uint32_t)(miso[2] & 0x0Fu) << 7) | ((uint32_t)miso[3] >> 1); /* B1 first, 11 bits */
    uint32_t msb_first = (uint32_t)code >> 1, reversed = 0;
    for (int i = 0; i < 11; i++) {
        reversed = (reversed << 1) | (msb_first & 1u);
        msb_first >>= 1;
    }
    return repeat == reversed;
}

void mcp3204_init(mcp3204_t *m, const uint8_t channels[MCP3204_CHANNELS])
{
    for (int i = 0; i < MCP3204_CHANNELS; i++) {
        m->channels[i] = channels[i];
        mcp3204_request(channels[i], m->mosi + MCP3204_FRAME * i);
        m->lengths[i] = MCP3204_FRAME;
    }
    m->counters = (mcp3204_counters_t){0, 0, 0, 0, 0};
}

int mcp3204_read(mcp3204_t *m, uint64_t t_ns, uint16_t codes[MCP3204_CHANNELS])
{
    uint8_t miso[MCP3204_FRAME * MCP3204_CHANNELS];
    int r = hal_spi_exchange(m->mosi, miso, m->lengths, MCP3204_CHANNELS, t_ns);
    if (r < 0)
        return r;
    if (r != HAL_SPI_DONE) {
        if (r == HAL_SPI_BUSY)
            m->counters.no_transfer++;
        else
            m->counters.failed_reads++;
        return 0;
    }
    for (int i = 0; i < MCP3204_CHANNELS; i++) {
        const uint8_t *reply = miso + MCP3204_FRAME * i;
        int code = mcp3204_decode(reply);
        if (code < 0) {
            m->counters.null_bit_errors++;
            m->counters.failed_reads++;
            hal_spi_resync(); /* wrong SPI mode or framing: re-apply the setup */
            return 0;
        }
        if (!mcp3204_repeat_agrees(reply, code)) {
            m->counters.repeat_errors++; /* a bit error on the line, not the framing */
            m->counters.failed_reads++;
            return 0;
        }
        codes[i] = (uint16_t)code;
    }
    m->counters.reads++;
    return 1;
}
