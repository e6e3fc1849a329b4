/* What the config-defaults test needs to see of fc_config_t: its size, and the key table. */
#include <stddef.h>

#include "config.h"
#include "config_keys.h"

size_t cfg_test_sizeof(void);
const cfg_key_t *cfg_test_keys(void);

size_t cfg_test_sizeof(void) { return sizeof(fc_config_t); }
const cfg_key_t *cfg_test_keys(void) { return cfg_keys; }
