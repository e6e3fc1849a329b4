/*
 * Structured one-line logging in logfmt, as flightcode/log.py:
 *   t_s=<sensor time> level=<level> event=<name> key=value ...
 * t_s is sensor time since the first IMU sample (0.000000 during boot). Values with spaces,
 * quotes, '=' or nothing at all are double-quoted with \ and " escaped; floats use 6
 * significant digits. Lines go to hal_log_line(). The loop logs events and a periodic stats
 * line, never per sample.
 *
 * Usage: if (log_begin(LOG_INFO, "mode")) { log_str("old", ...); ...; log_end(); }
 * One line is built at a time (the flight code runs one thread).
 */
#ifndef FW_LOG_H
#define FW_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum { LOG_DEBUG = 10, LOG_INFO = 20, LOG_WARNING = 30, LOG_ERROR = 40 } log_level_t;

void log_set_level(log_level_t level);
/* Sensor time of the current sample, ns since the first sample (0 during boot). */
void log_set_time_ns(int64_t t_ns);

/* Start a line; false (and nothing to do) when the level is filtered out. */
bool log_begin(log_level_t level, const char *event);
void log_str(const char *key, const char *value);
void log_int(const char *key, int64_t value);
void log_float(const char *key, double value);
void log_bool(const char *key, bool value);
void log_end(void);

/* v as printf's "%.6g" writes it, without printf's float path (cap >= 16). */
void log_format_g6(double v, char *out, size_t cap);

/* A whole line with one string field, for the common short events. */
void log_event(log_level_t level, const char *event);

#endif
