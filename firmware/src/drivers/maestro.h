/*
 * Pololu Maestro compact Set Multiple Targets (Maestro User's Guide 0J40 5.e):
 *   0x9F, n, first_channel, (target & 0x7F, (target >> 7) & 0x7F) x n
 * with targets in quarter-microseconds. One command carries all four motors, so each loop
 * sample costs exactly one write. Used by the posix hardware layer for hal_esc_write.
 */
#ifndef FW_MAESTRO_H
#define FW_MAESTRO_H

#include <stddef.h>
#include <stdint.h>

#define MAESTRO_SET_TARGET 0x84u
#define MAESTRO_SET_MULTIPLE_TARGETS 0x9Fu

/* The command for n consecutive channels from first_channel into out: its length, or 0 if a
 * target is outside 14 bits or it does not fit out_cap. */
size_t maestro_set_multiple_targets(uint8_t first_channel, const uint16_t *targets_qus, size_t n, uint8_t *out,
                                    size_t out_cap);

#endif
