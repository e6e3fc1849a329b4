/* logfmt lines: see log.h. */
#include "log.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "hal.h"

#define LOG_LINE_MAX 768

static struct {
    log_level_t level;
    int64_t t_ns;
    char line[LOG_LINE_MAX];
    size_t n;
    bool open;
} g_log = {LOG_INFO, 0, {0}, 0, false};

void log_set_level(log_level_t level) { g_log.level = level; }
void log_set_time_ns(int64_t t_ns) { g_log.t_ns = t_ns; }

static void put(const char *s, size_t n)
{
    if (g_log.n + n >= LOG_LINE_MAX)
        n = LOG_LINE_MAX - 1 - g_log.n; /* a line too long is cut, never overrun */
    memcpy(g_log.line + g_log.n, s, n);
    g_log.n += n;
}

static void put_value(const char *text)
{
    bool quote = text[0] == '\0' || strpbrk(text, " =\"\\\n\t") != NULL;
    if (!quote) {
        put(text, strlen(text));
        return;
    }
    put("\"", 1);
    for (const char *c = text; *c; c++) {
        if (*c == '\\' || *c == '"')
            put("\\", 1);
        if (*c == '\n')
            put("\\n", 2);
        else
            put(c, 1);
    }
    put("\"", 1);
}

static void put_key(const char *key)
{
    put(" ", 1);
    put(key, strlen(key));
    put("=", 1);
}

static const char *level_name(log_level_t level)
{
    switch (level) {
    case LOG_DEBUG: return "debug";
    case LOG_INFO: return "info";
    case LOG_WARNING: return "warning";
    default: return "error";
    }
}

bool log_begin(log_level_t level, const char *event)
{
    char head[64];
    int64_t t = g_log.t_ns;
    int64_t whole = t / 1000000000;
    int64_t frac_us = (t % 1000000000) / 1000;
    if (level < g_log.level)
        return false;
    if (frac_us < 0) { /* boot runs at negative virtual times on some benches: keep the sign */
        frac_us = -frac_us;
    }
    g_log.n = 0;
    g_log.open = true;
    snprintf(head, sizeof head, "t_s=%s%lld.%06lld level=%s event=", (t < 0 && whole == 0) ? "-" : "",
             (long long)whole, (long long)frac_us, level_name(level));
    put(head, strlen(head));
    put_value(event);
    return true;
}

void log_str(const char *key, const char *value)
{
    if (!g_log.open)
        return;
    put_key(key);
    put_value(value ? value : "");
}

void log_int(const char *key, int64_t value)
{
    char text[24];
    if (!g_log.open)
        return;
    snprintf(text, sizeof text, "%lld", (long long)value);
    put_key(key);
    put(text, strlen(text));
}

/* powers of ten 1e0..1e22: exact in double */
static const double POW10[23] = {1e0,  1e1,  1e2,  1e3,  1e4,  1e5,  1e6,  1e7,  1e8,  1e9,  1e10, 1e11,
                                 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22};

/* The rounding error of the product a x b: a x b - fl(a x b), exactly (Dekker's product with
 * Veltkamp's split; no fused multiply-add needed). */
static double product_error(double a, double b, double p)
{
    const double split = 134217729.0; /* 2^27 + 1 */
    double ta = split * a, tb = split * b;
    double ah = ta - (ta - a), al = a - ah;
    double bh = tb - (tb - b), bl = b - bh;
    return ((ah * bh - p) + ah * bl + al * bh) + al * bl;
}

/*
 * v as printf's "%.6g" writes it, without printf: six significant digits, exponent form below
 * 1e-4 and from 1e6 on, trailing zeros dropped. On the ARM7 printf's float path is newlib's dtoa
 * (arbitrary-precision soft-float arithmetic and malloc, about 0.1 ms a value at 60 MHz); this
 * is a few multiplications. The scaling by a power of ten rounds once, so in rare cases the
 * sixth digit may differ from printf's by one; nothing reads logs that closely.
 */
void log_format_g6(double v, char *out, size_t cap)
{
    char digits[8], *p = out;
    double a = v < 0 ? -v : v, m;
    int e = 0, nd;
    uint32_t d;
    if (cap < 16) {
        if (cap)
            out[0] = '\0';
        return;
    }
    if (isnan(v)) {
        strcpy(out, "nan");
        return;
    }
    if (isinf(v)) {
        strcpy(out, v < 0 ? "-inf" : "inf");
        return;
    }
    if (v < 0 || (v == 0 && 1.0 / v < 0))
        *p++ = '-';
    if (a == 0) {
        strcpy(p, "0");
        return;
    }
    if (a < 1e-22 || a >= 1e22) { /* beyond the table: rare enough for printf */
        snprintf(out, cap, "%.6g", v);
        return;
    }
    if (a >= 1.0) { /* a = m x 10^e, 1 <= m < 10 */
        while (e < 21 && a >= POW10[e + 1])
            e++;
    } else {
        e = -1;
        while (e > -22 && a * POW10[-e] < 1.0)
            e--;
    }
    if (5 - e <= 0) /* six digits before the point */
        m = a / POW10[e - 5];
    else if (5 - e <= 22)
        m = a * POW10[5 - e];
    else
        m = a * POW10[22] * POW10[5 - e - 22];
    d = (uint32_t)m;
    if (m - d > 0.5) {
        d++;
    } else if (m - d == 0.5) { /* a tie after the scaling's rounding: which side is the exact value? */
        double below; /* > 0: the exact scaled value is below m */
        if (5 - e <= 0)
            below = product_error(m, POW10[e - 5], m * POW10[e - 5]) + (m * POW10[e - 5] - a);
        else if (5 - e <= 22)
            below = -product_error(a, POW10[5 - e], m);
        else
            below = 0.0;
        if (below < 0 || (below == 0 && (d & 1u))) /* above the tie, or a true tie to even */
            d++;
    }
    if (d >= 1000000u) { /* 9.999995 rounds up to 10.0000 */
        d = (d + 5u) / 10u;
        e++;
    }
    for (int i = 5; i >= 0; i--) {
        digits[i] = (char)('0' + d % 10u);
        d /= 10u;
    }
    for (nd = 6; nd > 1 && digits[nd - 1] == '0'; nd--) {
    }
    if (e < -4 || e >= 6) {
        int x = e < 0 ? -e : e;
        *p++ = digits[0];
        if (nd > 1) {
            *p++ = '.';
            memcpy(p, digits + 1, (size_t)nd - 1);
            p += nd - 1;
        }
        *p++ = 'e';
        *p++ = e < 0 ? '-' : '+';
        if (x >= 100)
            *p++ = (char)('0' + x / 100);
        *p++ = (char)('0' + (x / 10) % 10);
        *p++ = (char)('0' + x % 10);
        *p = '\0';
        return;
    }
    if (e < 0) {
        *p++ = '0';
        *p++ = '.';
        for (int i = -1; i > e; i--)
            *p++ = '0';
        memcpy(p, digits, (size_t)nd);
        p += nd;
    } else {
        memcpy(p, digits, (size_t)e + 1 < (size_t)nd ? (size_t)e + 1 : (size_t)nd);
        for (int i = nd; i < e + 1; i++)
            p[i] = '0';
        p += e + 1;
        if (nd > e + 1) {
            *p++ = '.';
            memcpy(p, digits + e + 1, (size_t)(nd - e - 1));
            p += nd - e - 1;
        }
    }
    *p = '\0';
}

void log_float(const char *key, double value)
{
    char text[32];
    if (!g_log.open)
        return;
    log_format_g6(value, text, sizeof text);
    put_key(key);
    put(text, strlen(text));
}

void log_bool(const char *key, bool value) { log_str(key, value ? "true" : "false"); }

void log_end(void)
{
    if (!g_log.open)
        return;
    g_log.open = false;
    hal_log_line(g_log.line, g_log.n);
}

void log_event(log_level_t level, const char *event)
{
    if (log_begin(level, event))
        log_end();
}
