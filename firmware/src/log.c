/* logfmt lines: see log.h. */
#include "log.h"

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

void log_float(const char *key, double value)
{
    char text[32];
    if (!g_log.open)
        return;
    snprintf(text, sizeof text, "%.6g", value);
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
