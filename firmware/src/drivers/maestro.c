/* Maestro command encoding: see maestro.h. */
#include "drivers/maestro.h"

size_t maestro_set_multiple_targets(uint8_t first_channel, const uint16_t *targets_qus, size_t n, uint8_t *out,
                                    size_t out_cap)
{
    size_t k = 0;
    if (3 + 2 * n > out_cap)
        return 0;
    out[k++] = MAESTRO_SET_MULTIPLE_TARGETS;
    out[k++] = (uint8_t)n;
    out[k++] = first_channel;
    for (size_t i = 0; i < n; i++) {
        if (targets_qus[i] >= (1u << 14))
            return 0;
        out[k++] = (uint8_t)(targets_qus[i] & 0x7F);
        out[k++] = (uint8_t)((targets_qus[i] >> 7) & 0x7F);
    }
    return k;
}
