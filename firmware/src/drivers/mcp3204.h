/*
 * MCP3204 12-bit ADC (Microchip DS21298E), four single-ended channels a sample, through the
 * HAL's SPI exchange. Four bytes a conversion (SPI mode 0,0), the start bit at the second
 * clock (as Linux's mcp320x aligns it), so that 32 clocks carry the code MSB first and the
 * part's repeat of B1..B11 LSB first (section 5.0):
 *   MOSI 0 1 S D2 D1 D0 0 0 | 00000000 | 00000000          | 00000000    (S = 1 single-ended)
 *   MISO ? ? ? ? ? ? ? 0    | B11..B4  | B3..B0 B1..B4     | B5..B11 0   (hi-Z, the null bit)
 * so CH0..CH3 are 60 00 00 00, 64 00 00 00, 68 00 00 00, 6C 00 00 00.
 * A reply with the null bit set is no reading: the SPI path is set up again
 * (hal_spi_resync). A code whose repeat disagrees is no reading either (a bit flipped on the
 * line: SPI has no checksum), without a resync: the framing is fine. Never a misread code
 * (B0, sent once, is unchecked: one LSB).
 */
#ifndef FW_MCP3204_H
#define FW_MCP3204_H

#include <stdbool.h>
#include <stdint.h>

#define MCP3204_CHANNELS 4
#define MCP3204_NULL_BIT 0x01u /* in byte 0 */
#define MCP3204_FRAME 4 /* bytes of one conversion: the code MSB first, then its repeat */

/* The MCP3204_FRAME MOSI bytes converting channel 0..3 (single-ended). */
void mcp3204_request(uint8_t channel, uint8_t out[MCP3204_FRAME]);
/* The 12-bit code of a reply (MSB first: byte 1, the top of byte 2), or -1 if the null bit is
 * not 0. */
int mcp3204_decode(const uint8_t miso[MCP3204_FRAME]);
/* Whether the reply's LSB-first repeat (the low half of byte 2, byte 3) reads code's B1..B11. */
bool mcp3204_repeat_agrees(const uint8_t miso[MCP3204_FRAME], int code);

typedef struct {
    uint32_t reads, failed_reads, null_bit_errors, repeat_errors, no_transfer;
} mcp3204_counters_t;

typedef struct {
    uint8_t channels[MCP3204_CHANNELS];
    uint8_t mosi[MCP3204_FRAME * MCP3204_CHANNELS];
    uint8_t lengths[MCP3204_CHANNELS];
    mcp3204_counters_t counters;
} mcp3204_t;

/* channels: MCP3204 channel numbers in the order the codes are returned. */
void mcp3204_init(mcp3204_t *m, const uint8_t channels[MCP3204_CHANNELS]);

/* Codes of all channels for the sample at sensor time t_ns: 1 with codes filled, 0 when this
 * sample has none (counted: failed_reads if a request went out, else no_transfer), < 0 the
 * port itself failed (a hal_status_t). */
int mcp3204_read(mcp3204_t *m, uint64_t t_ns, uint16_t codes[MCP3204_CHANNELS]);

#endif
