/* The table of the config file's keys (config_keys.c): where each lands in fc_config_t and
 * how it is converted. Used by config.c only. */
#ifndef FW_CONFIG_KEYS_H
#define FW_CONFIG_KEYS_H

#include <stddef.h>

typedef enum {
    CK_FLOAT,  /* a number (an integer is taken as one), finite */
    CK_INT,    /* an integer */
    CK_BOOL,   /* true or false */
    CK_PATH,   /* a string (a port path) */
    CK_ENUM,   /* a string out of choices -> its index (int) */
    CK_INT_ENUM, /* an integer out of choices (ap_mode 1, 2) */
    CK_INT3,   /* an array of 3 integers */
    CK_MOUNT,  /* an array of 3 short strings */
    CK_BOOL_ENUM /* a string out of 2 choices -> false/true */
} cfg_kind_t;

typedef struct {
    const char *key;      /* dotted */
    cfg_kind_t kind;
    size_t offset;        /* into fc_config_t */
    const char *choices;  /* CK_ENUM/CK_BOOL_ENUM: "a|b|c"; CK_INT_ENUM: "1|2" */
} cfg_key_t;

extern const cfg_key_t cfg_keys[];
extern const size_t cfg_n_keys;

#endif
