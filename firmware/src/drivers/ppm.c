/* PPM capture records and decoder: see ppm.h. */
#include "drivers/ppm.h"

#include <string.h>

uint8_t crc8_smbus(const uint8_t *data, size_t n)
{
    uint8_t crc = 0;
    for (size_t i = 0; i < n; i++) {
        crc ^= data[i];
        for (int b = 0; b < 8; b++)
            crc = (uint8_t)((crc & 0x80) ? (crc << 1) ^ 0x07 : crc << 1);
    }
    return crc;
}

void capture_parser_init(capture_parser_t *p) { memset(p, 0, sizeof *p); }

size_t capture_parser_push(capture_parser_t *p, const uint8_t *data, size_t n)
{
    size_t room = sizeof p->buf - p->n;
    size_t take = n < room ? n : room;
    memcpy(p->buf + p->n, data, take);
    p->n += take;
    return take;
}

size_t capture_parser_pop(capture_parser_t *p, hal_edge_t *out, size_t max)
{
    size_t got = 0, i = 0;
    while (p->n - i >= CAPTURE_RECORD_LEN && got < max) {
        const uint8_t *r = p->buf + i;
        if (r[0] != CAPTURE_SYNC) {
            p->counters.garbage_bytes++;
            i++;
            continue;
        }
        if (crc8_smbus(r + 1, 4) != r[5]) {
            p->counters.crc_errors++;
            i++;
            continue;
        }
        if (r[2] & 0xFC) { /* reserved bits set: not a record after all */
            p->counters.bad_flags++;
            i++;
            continue;
        }
        out[got].seq = r[1];
        out[got].level = r[2] & 0x01;
        out[got].overrun = (r[2] & 0x02) != 0;
        out[got].t_us = (uint16_t)(r[3] | (r[4] << 8));
        got++;
        i += CAPTURE_RECORD_LEN;
    }
    memmove(p->buf, p->buf + i, p->n - i);
    p->n -= i;
    return got;
}

void ppm_init(ppm_decoder_t *d, const ppm_params_t *params)
{
    memset(d, 0, sizeof *d);
    d->params = *params;
    d->level = params->rising ? 1 : 0;
}

void ppm_desync(ppm_decoder_t *d)
{
    d->synced = false;
    d->n_channels = 0;
    d->have_t = false;
    d->have_level = false;
    d->have_seq = false;
}

static int complete(ppm_decoder_t *d, uint16_t out_us[PPM_MAX_CHANNELS])
{
    uint8_t n = d->n_channels;
    if (n < d->params.min_channels) {
        d->counters.short_frames++;
        return 0;
    }
    if (n == d->candidate) {
        if (d->stable < 255)
            d->stable++;
    } else {
        d->candidate = n;
        d->stable = 1;
    }
    if (n != d->locked_channels) {
        if (d->stable >= d->params.lock_frames) {
            d->locked_channels = n;
            d->counters.locks++;
        } else {
            d->counters.unlocked_frames++;
            return 0;
        }
    }
    d->counters.frames++;
    memcpy(out_us, d->channels, n * sizeof out_us[0]);
    return n;
}

int ppm_edge(ppm_decoder_t *d, const hal_edge_t *e, uint16_t out_us[PPM_MAX_CHANNELS])
{
    const ppm_params_t *p = &d->params;
    uint16_t width;
    if (d->have_seq && e->seq != (uint8_t)(d->last_seq + 1)) {
        d->counters.sequence_gaps++;
        ppm_desync(d);
    }
    if (e->overrun) {
        d->counters.overruns++;
        ppm_desync(d);
    }
    if (d->have_level && e->level == d->last_level) {
        d->counters.missing_edges++;
        ppm_desync(d);
    }
    d->have_seq = true;
    d->last_seq = e->seq;
    d->have_level = true;
    d->last_level = e->level;
    if (e->level != d->level)
        return 0;
    if (!d->have_t) {
        d->have_t = true;
        d->last_t = e->t_us;
        return 0;
    }
    width = (uint16_t)(e->t_us - d->last_t); /* the 16-bit timer wraps */
    d->last_t = e->t_us;
    if (width >= p->sync_min_us) {
        bool had = d->synced;
        int n = 0;
        if (had)
            n = complete(d, out_us);
        d->synced = true;
        d->n_channels = 0;
        return n;
    }
    if (p->pulse_min_us < width && width < p->pulse_max_us) {
        if (d->synced) {
            if (d->n_channels <= PPM_MAX_CHANNELS)
                d->channels[d->n_channels] = width;
            d->n_channels++;
            if (d->n_channels > p->max_channels) {
                d->counters.too_many_channels++;
                d->synced = false;
            }
        }
        return 0;
    }
    d->counters.bad_pulses++;
    d->synced = false;
    d->n_channels = 0;
    return 0;
}
