/* XSENS measurement payloads: see mtdata.h. */
#include "drivers/mtdata.h"

#include <math.h>
#include <string.h>

static uint16_t be16(const uint8_t *b) { return (uint16_t)((b[0] << 8) | b[1]); }
static uint32_t be32(const uint8_t *b)
{
    return ((uint32_t)b[0] << 24) | ((uint32_t)b[1] << 16) | ((uint32_t)b[2] << 8) | b[3];
}
static float be_f32(const uint8_t *b)
{
    uint32_t u = be32(b);
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

void mtdata_mk4_output_configuration(uint16_t rate_hz, uint8_t out[4 * MTDATA_MK4_ENTRIES])
{
    /* frequency 0xFFFF = "in every packet" (MT Manager capture, docs/protocols.md 1.9) */
    static const uint16_t xdi[MTDATA_MK4_ENTRIES] = {0x1020, 0x1060, 0x2034, 0x8024, 0x4024, 0xE020};
    static const bool every[MTDATA_MK4_ENTRIES] = {true, true, false, false, false, true};
    for (int i = 0; i < MTDATA_MK4_ENTRIES; i++) {
        uint16_t f = every[i] ? 0xFFFFu : rate_hz;
        out[4 * i] = (uint8_t)(xdi[i] >> 8);
        out[4 * i + 1] = (uint8_t)xdi[i];
        out[4 * i + 2] = (uint8_t)(f >> 8);
        out[4 * i + 3] = (uint8_t)f;
    }
}

uint16_t mtdata_legacy_period(uint32_t rate_hz)
{
    /* round half to even as Python's round(): 115200 / rate is never exactly .5 for the
     * accepted 100..512 Hz except where it is an integer */
    return (uint16_t)((MTDATA_LEGACY_PERIOD_CLOCK_HZ + rate_hz / 2u) / rate_hz);
}

size_t mtdata_legacy_length(uint16_t mode, uint32_t settings)
{
    size_t n = 0;
    if (mode & LEGACY_MODE_TEMPERATURE)
        n += 4;
    if (mode & LEGACY_MODE_CALIBRATED) {
        n += (settings & LEGACY_SET_DISABLE_ACC) ? 0 : 12;
        n += (settings & LEGACY_SET_DISABLE_GYR) ? 0 : 12;
        n += (settings & LEGACY_SET_DISABLE_MAG) ? 0 : 12;
    }
    if (mode & LEGACY_MODE_ORIENTATION) {
        static const uint8_t orient[4] = {16, 12, 36, 16};
        n += orient[(settings >> 2) & 0x3];
    }
    if (mode & LEGACY_MODE_AUXILIARY) {
        n += (settings & LEGACY_SET_DISABLE_AIN1) ? 0 : 2;
        n += (settings & LEGACY_SET_DISABLE_AIN2) ? 0 : 2;
    }
    if (mode & LEGACY_MODE_POSITION)
        n += 12;
    if (mode & LEGACY_MODE_VELOCITY)
        n += 12;
    if (mode & LEGACY_MODE_STATUS)
        n += 1;
    if ((settings & 0x3) == 1)
        n += 2;
    return n;
}

/* Three scalars of the given precision; false if the size is wrong or a value not finite. */
static bool vec3(const uint8_t *d, size_t len, int precision, float out[3])
{
    for (int i = 0; i < 3; i++) {
        double v;
        switch (precision) {
        case XDI_FLOAT32:
            if (len != 12)
                return false;
            v = be_f32(d + 4 * i);
            break;
        case XDI_FP1220:
            if (len != 12)
                return false;
            v = (double)(int32_t)be32(d + 4 * i) / 1048576.0;
            break;
        case XDI_FP1632: {
            if (len != 18)
                return false;
            uint32_t frac = be32(d + 6 * i);
            int16_t whole = (int16_t)be16(d + 6 * i + 4);
            v = ((double)whole * 4294967296.0 + (double)frac) / 4294967296.0;
            break;
        }
        default: {
            uint64_t u = 0;
            if (len != 24)
                return false;
            for (int k = 0; k < 8; k++)
                u = (u << 8) | d[8 * i + k];
            memcpy(&v, &u, sizeof v);
            break;
        }
        }
        if (!isfinite(v))
            return false;
        out[i] = (float)v;
    }
    return true;
}

/* The flight code's own mk4 layout at fixed offsets; false if laid out otherwise. */
static bool decode_mk4_fast(const uint8_t *p, size_t len, xsens_data_t *out)
{
    static const struct { uint8_t off; uint16_t xdi; uint8_t size; } hdr[6] = {
        {0, 0x1020, 2}, {5, 0x1060, 4}, {12, 0x2034, 12}, {27, 0x8024, 12}, {42, 0x4024, 12}, {57, 0xE020, 4}};
    if (len != MTDATA_MK4_PAYLOAD_LEN)
        return false;
    for (int i = 0; i < 6; i++)
        if (be16(p + hdr[i].off) != hdr[i].xdi || p[hdr[i].off + 2] != hdr[i].size)
            return false;
    out->counter = be16(p + 3);
    out->has_sample_time_fine = true;
    out->sample_time_fine = be32(p + 8);
    for (int i = 0; i < 3; i++) {
        out->euler_deg[i] = be_f32(p + 15 + 4 * i);
        out->rate_of_turn_radps[i] = be_f32(p + 30 + 4 * i);
        out->acceleration_mps2[i] = be_f32(p + 45 + 4 * i);
        if (!isfinite(out->euler_deg[i]) || !isfinite(out->rate_of_turn_radps[i]) ||
            !isfinite(out->acceleration_mps2[i]))
            return false; /* the general path counts what is wrong */
    }
    out->status = be32(p + 60);
    return true;
}

bool mtdata_decode2(const uint8_t *payload, size_t len, xsens_data_t *out, mtdata_counters_t *c)
{
    bool has_counter = false, has_stf = false, has_euler = false, has_gyr = false, has_acc = false;
    size_t off = 0;
    if (decode_mk4_fast(payload, len, out))
        return true;
    /* the packets must tile the payload exactly */
    while (off + 3 <= len) {
        size_t size = payload[off + 2];
        if (off + 3 + size > len)
            break;
        off += 3 + size;
    }
    if (off != len) {
        c->mtdata2_truncated++;
        return false;
    }
    memset(out, 0, sizeof *out);
    for (off = 0; off < len;) {
        uint16_t xdi = be16(payload + off);
        size_t size = payload[off + 2];
        const uint8_t *d = payload + off + 3;
        uint16_t kind = xdi & 0xFFF0u;
        int precision = xdi & 0x3;
        if (kind == XDI_PACKET_COUNTER && size == 2) {
            out->counter = be16(d);
            has_counter = true;
        } else if (kind == XDI_SAMPLE_TIME_FINE && size == 4) {
            out->sample_time_fine = be32(d);
            has_stf = true;
        } else if (kind == XDI_EULER_ANGLES) {
            has_euler = vec3(d, size, precision, out->euler_deg);
        } else if (kind == XDI_RATE_OF_TURN) {
            has_gyr = vec3(d, size, precision, out->rate_of_turn_radps);
        } else if (kind == XDI_ACCELERATION) {
            has_acc = vec3(d, size, precision, out->acceleration_mps2);
        } else if (kind == XDI_STATUS_WORD && size == 4) {
            out->status = be32(d);
        }
        off += 3 + size;
    }
    if (!(has_counter && has_stf && has_euler && has_gyr && has_acc)) {
        c->mtdata2_incomplete++;
        return false;
    }
    out->has_sample_time_fine = true;
    return true;
}

bool mtdata_decode_legacy(const uint8_t *payload, size_t len, uint16_t mode, uint32_t settings,
                          xsens_data_t *out, mtdata_counters_t *c)
{
    int precision = (settings & LEGACY_SET_FIXED_1220) ? XDI_FP1220 : XDI_FLOAT32;
    size_t off = (mode & LEGACY_MODE_TEMPERATURE) ? 4u : 0u;
    bool acc = false, gyr = false, euler;
    if (len != mtdata_legacy_length(mode, settings)) {
        c->mtdata_bad_length++;
        return false;
    }
    if (!((mode & LEGACY_MODE_CALIBRATED) && (mode & LEGACY_MODE_ORIENTATION)) || ((settings >> 2) & 0x3) != 1) {
        c->mtdata_unsupported_layout++;
        return false;
    }
    memset(out, 0, sizeof *out);
    if (!(settings & LEGACY_SET_DISABLE_ACC)) {
        acc = vec3(payload + off, 12, precision, out->acceleration_mps2);
        off += 12;
    }
    if (!(settings & LEGACY_SET_DISABLE_GYR)) {
        gyr = vec3(payload + off, 12, precision, out->rate_of_turn_radps);
        off += 12;
    }
    if (!(settings & LEGACY_SET_DISABLE_MAG))
        off += 12;
    euler = vec3(payload + off, 12, precision, out->euler_deg);
    if ((settings & 0x3) != 1 || !acc || !gyr || !euler) {
        c->mtdata_incomplete++;
        return false;
    }
    out->status = ((mode & LEGACY_MODE_STATUS) && (settings & 0x3) == 1) ? payload[len - 3] : 0u;
    out->counter = be16(payload + len - 2);
    out->has_sample_time_fine = false;
    return true;
}
