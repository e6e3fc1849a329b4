/*
 * A reader for the subset of TOML the flight config uses: comments, [table] and [a.b]
 * headers, bare or quoted (dotted) keys, basic and literal strings, integers (with _, 0x/0o/0b),
 * floats, booleans and one-line or multi-line arrays of those. Anything else (inline tables,
 * arrays of tables, multi-line strings, dates) is an error naming the line. No C TOML library
 * is packaged for both Debian and the ARM target, so the firmware carries this small one.
 *
 * Sans-I/O: the whole text in, one callback per key = value with the full dotted key.
 */
#ifndef FW_TOML_LITE_H
#define FW_TOML_LITE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define TOML_STR_MAX 256
#define TOML_ARRAY_MAX 4
#define TOML_KEY_MAX 96

typedef enum { TV_STRING, TV_INT, TV_FLOAT, TV_BOOL, TV_ARRAY, TV_TABLE } toml_type_t;

typedef struct toml_scalar {
    toml_type_t type;
    char s[TOML_STR_MAX];
    int64_t i;
    double f;
    bool b;
} toml_scalar_t;

/* An array element: short strings only (the config's arrays hold numbers and axis names),
 * which keeps a value small on the ARM7's stack. */
#define TOML_ITEM_STR_MAX 16
typedef struct {
    toml_type_t type;
    char s[TOML_ITEM_STR_MAX];
    int64_t i;
    double f;
    bool b;
} toml_item_t;

typedef struct {
    toml_type_t type; /* TV_TABLE: a [header] (no value) */
    toml_scalar_t v;  /* scalars */
    size_t n;         /* TV_ARRAY: elements (at most TOML_ARRAY_MAX kept, n counts all) */
    toml_item_t items[TOML_ARRAY_MAX];
} toml_value_t;

/* Called per key = value (and per [table] header, with TV_TABLE); return false to stop
 * (the callback has set its own error). */
typedef bool (*toml_fn)(void *ctx, const char *key, const toml_value_t *value);

/* Parse; false on a syntax error, with "line N: reason" in why (or the callback's stop). */
bool toml_parse(const char *text, size_t len, toml_fn fn, void *ctx, char *why, size_t why_len);

/* A float the way Python's repr shows it (0.0, -1.5, 1e-06, inf). */
void toml_float_repr(double f, char *out, size_t cap);

/* A value the way Python's repr shows it ('text', 30, 30.0, True, [1, 2]), for messages. */
void toml_repr(const toml_value_t *v, char *out, size_t cap);

#endif
