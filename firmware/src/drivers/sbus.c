/* SBUS frames: see sbus.h. */
#include "drivers/sbus.h"

#include <string.h>

void sbus_parser_init(sbus_parser_t *p) { memset(p, 0, sizeof *p); }

void sbus_decode_channels(const uint8_t payload[22], uint16_t raw[SBUS_N_CHANNELS])
{
    uint32_t bits = 0;
    int have = 0, k = 0;
    for (int i = 0; i < SBUS_N_CHANNELS; i++) {
        while (have < 11) {
            bits |= (uint32_t)payload[k++] << have;
            have += 8;
        }
        raw[i] = (uint16_t)(bits & 0x7FFu);
        bits >>= 11;
        have -= 11;
    }
}

static bool end_byte_ok(uint8_t b) { return b == 0x00 || b == 0x04 || b == 0x14 || b == 0x24 || b == 0x34; }

void sbus_parser_feed(sbus_parser_t *p, const uint8_t *data, size_t n,
                      void (*fn)(void *ctx, const sbus_frame_t *f), void *ctx)
{
    size_t used = 0;
    while (used < n) {
        size_t i = 0;
        size_t room = sizeof p->buf - p->n;
        size_t take = n - used < room ? n - used : room;
        memcpy(p->buf + p->n, data + used, take);
        p->n += take;
        used += take;
        while (p->n - i >= SBUS_FRAME_LEN) {
            const uint8_t *f = p->buf + i;
            sbus_frame_t frame;
            if (f[0] != SBUS_HEADER || !end_byte_ok(f[24]) || (f[23] & 0xF0)) {
                p->counters.garbage_bytes++;
                i++;
                continue;
            }
            sbus_decode_channels(f + 1, frame.raw);
            frame.flags = f[23];
            p->counters.frames++;
            if (fn)
                fn(ctx, &frame);
            i += SBUS_FRAME_LEN;
        }
        memmove(p->buf, p->buf + i, p->n - i);
        p->n -= i;
    }
}
