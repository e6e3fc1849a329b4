/* The flight config: see config.h. Structural checks here (config_keys.c says where each
 * key goes), then the semantic checks of flightcode/config.py's _check. */
#include "config.h"

#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config_keys.h"
#include "drivers/analog.h"
#include "drivers/buspirate.h"
#include "log.h"
#include "toml_lite.h"

/* A value as Python's str() shows it in a message: integers plain, floats as the shortest
 * text that reads back as the same single-precision value (the config holds float32). */
static const char *num(double v, bool is_int, char *buf, size_t cap)
{
    float f = (float)v;
    if (is_int) {
        snprintf(buf, cap, "%lld", (long long)v);
        return buf;
    }
    if (!isfinite(f) || (f == floorf(f) && fabsf(f) < 1e16f)) {
        toml_float_repr((double)f, buf, cap);
        return buf;
    }
    for (int prec = 1; prec <= 9; prec++) {
        snprintf(buf, cap, "%.*g", prec, (double)f);
        if (strtof(buf, NULL) == f)
            break;
    }
    return buf;
}

void cfg_defaults(fc_config_t *c)
{
    memset(c, 0, sizeof *c);
    c->imu.identity = CFG_IMU_MK4;
    c->imu.rate_hz = 400;
    c->imu.goto_config_attempts = 10;
    c->imu.reply_timeout_s = 0.25f;
    c->adc.spi_speed_hz = 1000000;
    c->adc.vref_V = 5.0f;
    c->adc.baro_channel = 0;
    c->adc.accel_channels[0] = 1;
    c->adc.accel_channels[1] = 2;
    c->adc.accel_channels[2] = 3;
    c->adc.read_timeout_s = 0.02f;
    c->adc.entry_attempts = 5;
    c->adc.reply_timeout_s = 0.2f;
    c->adc.quiet_s = 0.03f;
    c->adc.resync_interval_s = 0.25f;
    c->adc.baro.supply_V = 5.0f;
    c->adc.baro.k_per_kPa = 0.009f;
    c->adc.baro.offset_ratio = 0.095f;
    c->adc.baro.gain = 16.0f;
    c->adc.baro.offset_V = 3.928375f;
    c->adc.baro.ref_V = 0.0f;
    c->adc.baro.zero_average_s = 1.0f;
    c->adc.baro.rail_margin_V = 0.05f;
    c->adc.accel.supply_V = 3.3f;
    c->adc.accel.zero_g_ratio = 0.5f;
    c->adc.accel.sens_ratio_per_g = 0.1f;
    strcpy(c->adc.accel.mount_B[0], "+X");
    strcpy(c->adc.accel.mount_B[1], "-Y");
    strcpy(c->adc.accel.mount_B[2], "-Z");
    c->rc.frontend = CFG_RC_CAPTURE;
    c->rc.channel_roll = 1;
    c->rc.channel_pitch = 2;
    c->rc.channel_throttle = 3;
    c->rc.channel_yaw = 4;
    c->rc.center_us = 1500.0f;
    c->rc.half_range_us = 500.0f;
    c->rc.throttle_low_us = 1000.0f;
    c->rc.throttle_range_us = 1000.0f;
    c->rc.max_angle_deg = 30.0f;
    c->rc.max_yaw_rate_dps = 90.0f;
    c->rc.capture.sync_min_us = 2700;
    c->rc.capture.pulse_min_us = 700;
    c->rc.capture.pulse_max_us = 2300;
    c->rc.capture.min_channels = 5;
    c->rc.capture.max_channels = 16;
    c->rc.capture.lock_frames = 25;
    c->rc.capture.rising = false;
    c->rc.capture.stale_ms = 50.0f;
    c->rc.sbus.scale_us = 0.625f;
    c->rc.sbus.offset_us = 875.0f;
    c->esc.min_us = 1000.0f;
    c->esc.max_us = 2000.0f;
    c->esc.idle_us = 1100.0f;
    c->esc.first_channel = 0;
    c->vehicle.frame = CFG_FRAME_X;
    c->vehicle.arm_m = 0.25f;
    c->vehicle.F_max_N = 20.6f;
    c->vehicle.kq_over_kt_m = 0.016f;
    c->vehicle.m_kg = 1.1f;
    c->vehicle.mixer = CFG_MIXER_THROTTLE;
    c->attitude.law = CFG_LAW_GENERALISED;
    c->attitude.omega1_radps = 2.0f;
    c->attitude.omega2_radps = 15.0f;
    c->attitude.k0_per_s = 2.0f;
    c->attitude.J_hat_kgm2 = 0.015f;
    c->attitude.tau_ff_s = 0.020f;
    c->attitude.u_limit_Nm = 0.8f;
    c->attitude.prefilter_omega_radps = 8.0f;
    c->yaw.kp_Nm_per_radps = 0.15f;
    c->yaw.ki_Nm_per_rad = 0.15f;
    c->yaw.u_limit_Nm = 0.15f;
    c->altitude.T1_s = 0.08f;
    c->altitude.q_int = 8.25e-3f;
    c->altitude.r = 1.0f;
    c->altitude.alt_range_m = 10.0f;
    c->altitude.takeoff_alt_m = 0.5f;
    c->kf.accel_source = CFG_ACCEL_ADXL335;
    c->kf.q_a = 2.0f;
    c->kf.q_d = 0.05f;
    c->kf.q_b = 1e-6f;
    c->kf.r_baro_m2 = 0.33f;
    c->kf.r_acc = 0.091f;
    c->kf.r_rest_vz = 0.0025f;
    c->kf.rest_after_s = 1.0f;
    c->kf.ground_effect_alt_m = 1.0f;
    c->kf.ground_effect_r_scale = 25.0f;
    c->kf.baro_gate_chi2 = 25.0f;
    c->kf.baro_gate_timeout_s = 1.0f;
    c->plausibility.baro_max_step_Pa = 60.0f;
    c->plausibility.baro_flat_readings = 40;
    c->plausibility.baro_flat_std_Pa = 1.5f;
    c->plausibility.accel_max_g = 5.0f;
    c->plausibility.accel_xsens_tolerance_mps2 = 3.0f;
    c->plausibility.accel_offset_tau_s = 1.0f;
    c->plausibility.accel_offset_max_mps2 = 0.25f;
    c->plausibility.baro_motion_window_s = 1.5f;
    c->plausibility.baro_motion_block_s = 0.25f;
    c->plausibility.baro_motion_max_m = 1.5f;
    c->failsafe.rc_loss_s = 0.5f;
    c->failsafe.descend_mps = 0.5f;
    c->failsafe.imu_timeout_s = 0.1f;
    c->telemetry.enable = true;
    c->telemetry.ap_mode = 1;
    c->telemetry.dest16 = 0;
    c->telemetry.divider = 8;
    c->telemetry.request_status = false;
    c->telemetry.max_out_waiting = 256;
    c->modes.gesture_throttle_max_us = 1050.0f;
    c->modes.arm_yaw_min_us = 1900.0f;
    c->modes.disarm_yaw_max_us = 1100.0f;
    c->modes.gesture_hold_s = 1.0f;
    c->modes.landed_alt_m = 1.0f;
    c->modes.landed_vz_mps = 0.3f;
    c->modes.landed_collective_ratio = 0.7f;
    c->modes.landed_accel_mps2 = 1.0f;
    c->modes.landed_s = 1.0f;
    c->modes.auto_disarm_s = 5.0f;
    c->log.level = LOG_INFO;
    c->log.stats_period_s = 1.0f;
}

/* -- errors --------------------------------------------------------------------------------- */

static bool error(cfg_error_t *err, const char *key, const char *fmt, ...)
{
    va_list ap;
    snprintf(err->key, sizeof err->key, "%s", key);
    va_start(ap, fmt);
    vsnprintf(err->reason, sizeof err->reason, fmt, ap);
    va_end(ap);
    return false;
}

void cfg_error_format(const cfg_error_t *err, char *out, size_t cap)
{
    if (err->key[0])
        snprintf(out, cap, "%s: %s: %s", err->file, err->key, err->reason);
    else
        snprintf(out, cap, "%s: %s", err->file, err->reason);
}

/* -- structure: each key to its field --------------------------------------------------------- */

typedef struct {
    fc_config_t *cfg;
    cfg_error_t *err;
    bool seen_ports, seen_port[5], seen_path[5], seen_baud[5];
} apply_t;

static const char *const port_names[5] = {"imu", "adc", "rc", "esc", "telemetry"};

/* "known here" for a table prefix ("" = top level): the sorted, distinct next components
 * (pointers into the key table: nothing copied). */
static void known_here(const char *prefix, char *out, size_t cap)
{
    struct { const char *p; size_t n; } names[64];
    size_t n = 0, plen = strlen(prefix), k = 0;
    for (size_t i = 0; i < cfg_n_keys && n < 64; i++) {
        const char *key = cfg_keys[i].key, *rest, *dot;
        size_t m;
        bool dup = false;
        if (plen && (strncmp(key, prefix, plen) != 0 || key[plen] != '.'))
            continue;
        rest = plen ? key + plen + 1 : key;
        dot = strchr(rest, '.');
        m = dot ? (size_t)(dot - rest) : strlen(rest);
        for (size_t j = 0; j < n && !dup; j++)
            dup = names[j].n == m && !strncmp(names[j].p, rest, m);
        if (!dup) {
            names[n].p = rest;
            names[n].n = m;
            n++;
        }
    }
    for (size_t i = 1; i < n; i++) /* insertion sort: a few dozen names */
        for (size_t j = i; j > 0; j--) {
            size_t m = names[j - 1].n < names[j].n ? names[j - 1].n : names[j].n;
            int c = strncmp(names[j - 1].p, names[j].p, m);
            if (c < 0 || (c == 0 && names[j - 1].n <= names[j].n))
                break;
            {
                const char *tp = names[j].p;
                size_t tn = names[j].n;
                names[j] = names[j - 1];
                names[j - 1].p = tp;
                names[j - 1].n = tn;
            }
        }
    out[0] = '\0';
    for (size_t i = 0; i < n && k + 2 < cap; i++)
        k += (size_t)snprintf(out + k, cap - k, "%s%.*s", i ? ", " : "", (int)names[i].n, names[i].p);
}

static bool is_table(const char *path)
{
    size_t n = strlen(path);
    for (size_t i = 0; i < cfg_n_keys; i++)
        if (!strncmp(cfg_keys[i].key, path, n) && cfg_keys[i].key[n] == '.')
            return true;
    return false;
}

static const cfg_key_t *find_key(const char *key)
{
    for (size_t i = 0; i < cfg_n_keys; i++)
        if (!strcmp(cfg_keys[i].key, key))
            return &cfg_keys[i];
    return NULL;
}

/* Walk key's components: the first that is neither a table nor a key is unknown. */
static bool check_path(apply_t *a, const char *key, bool header, const toml_value_t *v)
{
    /* static: the config is read once, at boot, by one thread; the ARM7's stack stays small */
    static char known[400], got[300];
    char path[2 * TOML_KEY_MAX] = "";
    const char *p = key;
    for (;;) {
        const char *dot = strchr(p, '.');
        size_t m = dot ? (size_t)(dot - p) : strlen(p);
        char parent[2 * TOML_KEY_MAX];
        size_t plen = strlen(path);
        snprintf(parent, sizeof parent, "%s", path);
        if (plen)
            path[plen++] = '.';
        memcpy(path + plen, p, m);
        path[plen + m] = '\0';
        if (find_key(path)) {
            if (dot || header) /* a table where a value belongs */
                return error(a->err, path, "must be %s (got a table)",
                             find_key(path)->kind == CK_FLOAT ? "a number" : "a value");
            return true;
        }
        if (!is_table(path)) {
            known_here(parent, known, sizeof known);
            return error(a->err, path, "unknown key (known here: %s)", known);
        }
        if (!dot) {
            if (header)
                return true;
            toml_repr(v, got, sizeof got);
            return error(a->err, path, "must be a table (got %s)", got);
        }
        p = dot + 1;
    }
}

static bool to_float(apply_t *a, const char *key, const toml_scalar_t *s, const toml_value_t *whole, float *out)
{
    char got[300];
    toml_value_t tmp;
    if (s->type == TV_FLOAT || s->type == TV_INT) {
        double x = s->type == TV_FLOAT ? s->f : (double)s->i;
        if (!isfinite(x)) {
            memset(&tmp, 0, sizeof tmp);
            tmp.type = TV_FLOAT;
            tmp.v = *s;
            toml_repr(&tmp, got, sizeof got);
            return error(a->err, key, "must be finite (got %s)", got);
        }
        *out = (float)x;
        return true;
    }
    toml_repr(whole, got, sizeof got);
    return error(a->err, key, "must be a number (got %s)", got);
}

static bool choose(apply_t *a, const char *key, const char *choices, const toml_value_t *v, bool ints, int *index)
{
    char list[200] = "", got[300];
    const char *c = choices;
    int i = 0;
    size_t k = 0;
    while (*c) {
        const char *bar = strchr(c, '|');
        size_t m = bar ? (size_t)(bar - c) : strlen(c);
        bool match;
        if (ints)
            match = v->type == TV_INT && (size_t)snprintf(got, sizeof got, "%lld", (long long)v->v.i) == m &&
                    !strncmp(got, c, m);
        else
            match = v->type == TV_STRING && strlen(v->v.s) == m && !strncmp(v->v.s, c, m);
        if (match) {
            *index = i;
            return true;
        }
        k += (size_t)snprintf(list + k, sizeof list - k, ints ? "%s%.*s" : "%s'%.*s'", i ? ", " : "", (int)m, c);
        i++;
        c = bar ? bar + 1 : c + m;
    }
    toml_repr(v, got, sizeof got);
    return error(a->err, key, "must be one of %s (got %s)", list, got);
}

static bool on_value(void *ctx, const char *key, const toml_value_t *v)
{
    apply_t *a = ctx;
    const cfg_key_t *k;
    char *base = (char *)a->cfg;
    static char got[300]; /* boot only, one thread: off the ARM7's stack */
    if (!check_path(a, key, v->type == TV_TABLE, v))
        return false;
    if (!strncmp(key, "ports", 5) && (key[5] == '.' || key[5] == '\0')) {
        a->seen_ports = true;
        for (int i = 0; i < 5; i++) {
            size_t n = strlen(port_names[i]);
            if (!strncmp(key + 6, port_names[i], n) && (key[6 + n] == '.' || key[6 + n] == '\0')) {
                a->seen_port[i] = true;
                if (!strcmp(key + 6 + n, ".path"))
                    a->seen_path[i] = true;
                if (!strcmp(key + 6 + n, ".baud"))
                    a->seen_baud[i] = true;
            }
        }
    }
    if (v->type == TV_TABLE)
        return true;
    k = find_key(key);
    toml_repr(v, got, sizeof got);
    switch (k->kind) {
    case CK_FLOAT:
        if (v->type == TV_ARRAY)
            return error(a->err, key, "must be a number (got %s)", got);
        return to_float(a, key, &v->v, v, (float *)(base + k->offset));
    case CK_INT:
        if (v->type != TV_INT)
            return error(a->err, key, "must be an integer (got %s)", got);
        *(int64_t *)(base + k->offset) = v->v.i;
        return true;
    case CK_BOOL:
        if (v->type != TV_BOOL)
            return error(a->err, key, "must be true or false (got %s)", got);
        *(bool *)(base + k->offset) = v->v.b;
        return true;
    case CK_PATH:
        if (v->type != TV_STRING)
            return error(a->err, key, "must be a string (got %s)", got);
        if (strlen(v->v.s) >= CFG_PATH_MAX)
            return error(a->err, key, "longer than %d characters", CFG_PATH_MAX - 1);
        strcpy((char *)(base + k->offset), v->v.s);
        return true;
    case CK_ENUM:
    case CK_BOOL_ENUM:
    case CK_INT_ENUM: {
        int index = 0;
        if (!choose(a, key, k->choices, v, k->kind == CK_INT_ENUM, &index))
            return false;
        if (!strcmp(key, "adc.bridge"))
            return true; /* one choice, nothing to store */
        if (k->kind == CK_BOOL_ENUM)
            *(bool *)(base + k->offset) = index == 1;
        else if (k->kind == CK_INT_ENUM)
            *(int64_t *)(base + k->offset) = index + 1;
        else if (!strcmp(key, "log.level"))
            *(int *)(base + k->offset) = (index + 1) * 10;
        else
            *(int *)(base + k->offset) = index; /* every enum field is an int-sized enum */
        return true;
    }
    case CK_INT3:
    case CK_MOUNT: {
        char item_key[120];
        if (v->type != TV_ARRAY)
            return error(a->err, key, "must be an array of 3 values (got %s)", got);
        if (v->n != 3)
            return error(a->err, key, "must have exactly 3 elements (got %lu)", (unsigned long)v->n);
        for (int i = 0; i < 3; i++) {
            const toml_item_t *it = &v->items[i];
            toml_value_t one;
            memset(&one, 0, sizeof one);
            one.type = it->type;
            one.v.type = it->type;
            memcpy(one.v.s, it->s, TOML_ITEM_STR_MAX);
            one.v.i = it->i;
            one.v.f = it->f;
            one.v.b = it->b;
            toml_repr(&one, got, sizeof got);
            snprintf(item_key, sizeof item_key, "%s[%d]", key, i);
            if (k->kind == CK_INT3) {
                if (one.type != TV_INT)
                    return error(a->err, item_key, "must be an integer (got %s)", got);
                ((int64_t *)(base + k->offset))[i] = one.v.i;
            } else {
                if (one.type != TV_STRING)
                    return error(a->err, item_key, "must be a string (got %s)", got);
                snprintf(((char(*)[4])(base + k->offset))[i], 4, "%.3s", one.v.s);
                if (strlen(one.v.s) > 3) /* longer than any valid entry: parse_mount will refuse it */
                    ((char(*)[4])(base + k->offset))[i][0] = '?';
            }
        }
        return true;
    }
    }
    return true;
}

/* -- semantics (flightcode/config.py _check) ----------------------------------------------------- */

#define NEED(cond, key, ...) \
    do { \
        if (!(cond)) \
            return error(err, key, __VA_ARGS__); \
    } while (0)

static bool is_int_key(const char *key)
{
    for (size_t i = 0; i < cfg_n_keys; i++)
        if (!strcmp(cfg_keys[i].key, key))
            return cfg_keys[i].kind == CK_INT;
    return false;
}

static bool check(const fc_config_t *c, cfg_error_t *err)
{
    const struct { const char *key; double v; } positive[] = { /* integer keys: see is_int_key */
        {"imu.rate_hz", (double)c->imu.rate_hz}, {"imu.reply_timeout_s", c->imu.reply_timeout_s},
        {"adc.vref_V", c->adc.vref_V}, {"adc.read_timeout_s", c->adc.read_timeout_s},
        {"adc.reply_timeout_s", c->adc.reply_timeout_s}, {"adc.resync_interval_s", c->adc.resync_interval_s},
        {"adc.quiet_s", c->adc.quiet_s}, {"adc.baro.supply_V", c->adc.baro.supply_V},
        {"adc.baro.k_per_kPa", c->adc.baro.k_per_kPa}, {"adc.baro.gain", c->adc.baro.gain},
        {"adc.baro.zero_average_s", c->adc.baro.zero_average_s}, {"adc.accel.supply_V", c->adc.accel.supply_V},
        {"adc.accel.sens_ratio_per_g", c->adc.accel.sens_ratio_per_g}, {"rc.half_range_us", c->rc.half_range_us},
        {"rc.throttle_range_us", c->rc.throttle_range_us}, {"rc.max_angle_deg", c->rc.max_angle_deg},
        {"rc.max_yaw_rate_dps", c->rc.max_yaw_rate_dps}, {"vehicle.arm_m", c->vehicle.arm_m},
        {"vehicle.F_max_N", c->vehicle.F_max_N}, {"vehicle.kq_over_kt_m", c->vehicle.kq_over_kt_m},
        {"vehicle.m_kg", c->vehicle.m_kg}, {"attitude.J_hat_kgm2", c->attitude.J_hat_kgm2},
        {"attitude.u_limit_Nm", c->attitude.u_limit_Nm},
        {"attitude.prefilter_omega_radps", c->attitude.prefilter_omega_radps},
        {"attitude.omega1_radps", c->attitude.omega1_radps}, {"attitude.omega2_radps", c->attitude.omega2_radps},
        {"yaw.u_limit_Nm", c->yaw.u_limit_Nm}, {"altitude.T1_s", c->altitude.T1_s},
        {"altitude.q_int", c->altitude.q_int}, {"altitude.r", c->altitude.r},
        {"altitude.alt_range_m", c->altitude.alt_range_m}, {"kf.r_baro_m2", c->kf.r_baro_m2},
        {"kf.r_acc", c->kf.r_acc}, {"kf.r_rest_vz", c->kf.r_rest_vz}, {"failsafe.rc_loss_s", c->failsafe.rc_loss_s},
        {"failsafe.descend_mps", c->failsafe.descend_mps}, {"failsafe.imu_timeout_s", c->failsafe.imu_timeout_s},
        {"telemetry.divider", (double)c->telemetry.divider}, {"log.stats_period_s", c->log.stats_period_s},
        {"modes.gesture_hold_s", c->modes.gesture_hold_s}, {"modes.landed_s", c->modes.landed_s},
        {"modes.landed_vz_mps", c->modes.landed_vz_mps}, {"kf.baro_gate_chi2", c->kf.baro_gate_chi2},
        {"plausibility.baro_max_step_Pa", c->plausibility.baro_max_step_Pa},
        {"plausibility.baro_flat_std_Pa", c->plausibility.baro_flat_std_Pa},
        {"plausibility.accel_max_g", c->plausibility.accel_max_g},
        {"plausibility.accel_xsens_tolerance_mps2", c->plausibility.accel_xsens_tolerance_mps2},
        {"plausibility.accel_offset_tau_s", c->plausibility.accel_offset_tau_s},
        {"plausibility.accel_offset_max_mps2", c->plausibility.accel_offset_max_mps2},
        {"plausibility.baro_motion_block_s", c->plausibility.baro_motion_block_s},
        {"plausibility.baro_motion_max_m", c->plausibility.baro_motion_max_m},
        {"rc.capture.lock_frames", (double)c->rc.capture.lock_frames},
        {"rc.capture.stale_ms", c->rc.capture.stale_ms},
    };
    const struct { const char *key; double v; } non_negative[] = {
        {"attitude.k0_per_s", c->attitude.k0_per_s}, {"attitude.tau_ff_s", c->attitude.tau_ff_s},
        {"yaw.kp_Nm_per_radps", c->yaw.kp_Nm_per_radps}, {"yaw.ki_Nm_per_rad", c->yaw.ki_Nm_per_rad},
        {"altitude.q_z", c->altitude.q_z}, {"altitude.q_vz", c->altitude.q_vz}, {"altitude.q_az", c->altitude.q_az},
        {"altitude.takeoff_alt_m", c->altitude.takeoff_alt_m}, {"kf.q_a", c->kf.q_a}, {"kf.q_d", c->kf.q_d},
        {"kf.q_b", c->kf.q_b}, {"kf.rest_after_s", c->kf.rest_after_s},
        {"kf.ground_effect_alt_m", c->kf.ground_effect_alt_m},
        {"telemetry.max_out_waiting", (double)c->telemetry.max_out_waiting},
        {"kf.baro_gate_timeout_s", c->kf.baro_gate_timeout_s},
    };
    const cfg_port_t *ports[5] = {&c->ports.imu, &c->ports.adc, &c->ports.rc, &c->ports.esc, &c->ports.telemetry};
    const char *const mount[3] = {c->adc.accel.mount_B[0], c->adc.accel.mount_B[1], c->adc.accel.mount_B[2]};
    uint8_t axis[3];
    int8_t sign[3];
    int64_t rc_ch[4] = {c->rc.channel_roll, c->rc.channel_pitch, c->rc.channel_throttle, c->rc.channel_yaw};
    int64_t adc_ch[4] = {c->adc.baro_channel, c->adc.accel_channels[0], c->adc.accel_channels[1],
                         c->adc.accel_channels[2]};
    int64_t max_rc = 0;
    unsigned adc_seen = 0, rc_seen_ok = 1;

    char b[40];
    for (size_t i = 0; i < sizeof positive / sizeof positive[0]; i++)
        NEED(positive[i].v > 0, positive[i].key, "must be > 0 (got %s)",
             num(positive[i].v, is_int_key(positive[i].key), b, sizeof b));
    NEED(c->plausibility.baro_flat_readings == 0 || c->plausibility.baro_flat_readings >= 2,
         "plausibility.baro_flat_readings", "must be 0 (off) or >= 2 (got %lld)",
         (long long)c->plausibility.baro_flat_readings);
    NEED(c->plausibility.baro_motion_window_s == 0 ||
             c->plausibility.baro_motion_window_s >= 2 * c->plausibility.baro_motion_block_s,
         "plausibility.baro_motion_window_s",
         "must be 0 (off) or at least two blocks of baro_motion_block_s (got %s)",
         num(c->plausibility.baro_motion_window_s, false, b, sizeof b));
    NEED(c->adc.baro.rail_margin_V >= 0.0f && c->adc.baro.rail_margin_V < 0.25f * c->adc.vref_V,
         "adc.baro.rail_margin_V", "must be >= 0 and < a quarter of vref_V (got %s)",
         num(c->adc.baro.rail_margin_V, false, b, sizeof b));
    for (size_t i = 0; i < sizeof non_negative / sizeof non_negative[0]; i++)
        NEED(non_negative[i].v >= 0, non_negative[i].key, "must be >= 0 (got %s)",
             num(non_negative[i].v, is_int_key(non_negative[i].key), b, sizeof b));
    for (int i = 0; i < 5; i++) {
        char key[40];
        if (!ports[i]->present)
            continue;
        snprintf(key, sizeof key, "ports.%s.path", port_names[i]);
        NEED(ports[i]->path[0] != '\0', key, "must not be empty");
        snprintf(key, sizeof key, "ports.%s.baud", port_names[i]);
        NEED(ports[i]->baud > 0, key, "must be > 0 (got %lld)", (long long)ports[i]->baud);
    }
    if (c->imu.identity == CFG_IMU_MK4) {
        NEED(400 % c->imu.rate_hz == 0, "imu.rate_hz", "a mk4 outputs at divisors of 400 Hz (got %lld)",
             (long long)c->imu.rate_hz);
    } else {
        double period = floor(115200.0 / (double)c->imu.rate_hz + 0.5);
        NEED(period >= 225 && period <= 1152, "imu.rate_hz", "legacy MTi rates are 100..512 Hz (got %lld)",
             (long long)c->imu.rate_hz);
    }
    NEED(c->imu.goto_config_attempts >= 1, "imu.goto_config_attempts", "must be >= 1");
    NEED(bp_speed_code((uint32_t)c->adc.spi_speed_hz) >= 0 && c->adc.spi_speed_hz <= 8000000, "adc.spi_speed_hz",
         "must be one of 30000, 125000, 250000, 1000000, 2000000, 2600000, 4000000, 8000000 (got %lld)",
         (long long)c->adc.spi_speed_hz);
    NEED(c->adc.entry_attempts >= 1, "adc.entry_attempts", "must be >= 1");
    for (int i = 0; i < 4; i++) {
        if (adc_ch[i] < 0 || adc_ch[i] > 3 || (adc_seen & (1u << adc_ch[i])))
            adc_seen = 0x100;
        else
            adc_seen |= 1u << adc_ch[i];
    }
    NEED(adc_seen == 0xF, "adc.accel_channels",
         "baro_channel and accel_channels must be four different MCP3204 channels 0..3 (got (%lld, %lld, %lld, %lld))",
         (long long)adc_ch[0], (long long)adc_ch[1], (long long)adc_ch[2], (long long)adc_ch[3]);
    if (!analog_parse_mount(mount, axis, sign))
        return error(err, "adc.accel.mount_B", "must be a sign and an axis for each body axis, each sensor axis "
                                               "X, Y, Z once (got ['%s', '%s', '%s'])",
                     mount[0], mount[1], mount[2]);
    for (int i = 0; i < 4; i++) {
        if (rc_ch[i] < 1 || rc_ch[i] > 16)
            rc_seen_ok = 0;
        for (int j = 0; j < i; j++)
            if (rc_ch[i] == rc_ch[j])
                rc_seen_ok = 0;
        if (rc_ch[i] > max_rc)
            max_rc = rc_ch[i];
    }
    NEED(rc_seen_ok, "rc.channel_roll",
         "roll/pitch/throttle/yaw channels must be four different numbers 1..16 (got (%lld, %lld, %lld, %lld))",
         (long long)rc_ch[0], (long long)rc_ch[1], (long long)rc_ch[2], (long long)rc_ch[3]);
    NEED(0 < c->rc.capture.pulse_min_us && c->rc.capture.pulse_min_us < c->rc.capture.pulse_max_us &&
             c->rc.capture.pulse_max_us < c->rc.capture.sync_min_us && c->rc.capture.sync_min_us < 65536,
         "rc.capture.sync_min_us", "need 0 < pulse_min_us < pulse_max_us < sync_min_us");
    NEED(1 <= c->rc.capture.min_channels && c->rc.capture.min_channels <= c->rc.capture.max_channels,
         "rc.capture.min_channels", "need 1 <= min_channels <= max_channels");
    NEED(c->rc.capture.max_channels <= 16, "rc.capture.max_channels", "must be <= 16 (got %lld)",
         (long long)c->rc.capture.max_channels);
    NEED(c->rc.capture.lock_frames <= 255, "rc.capture.lock_frames", "must be <= 255 (got %lld)",
         (long long)c->rc.capture.lock_frames);
    NEED(c->rc.capture.min_channels >= max_rc, "rc.capture.min_channels", "must be >= the highest stick channel %lld",
         (long long)max_rc);
    NEED(c->rc.capture.stale_ms < 65.5f, "rc.capture.stale_ms", "must be below the 65.5 ms capture-timer wrap");
    NEED(0 < c->esc.min_us && c->esc.min_us <= c->esc.idle_us && c->esc.idle_us < c->esc.max_us &&
             c->esc.max_us <= 4095,
         "esc.idle_us", "need 0 < min_us <= idle_us < max_us");
    NEED(0 <= c->esc.first_channel && c->esc.first_channel <= 20, "esc.first_channel", "must be 0..20 (Maestro channels)");
    NEED(c->vehicle.m_kg * 9.80665f < c->vehicle.F_max_N, "vehicle.F_max_N", "cannot lift m_kg");
    NEED(c->altitude.takeoff_alt_m < c->altitude.alt_range_m, "altitude.takeoff_alt_m", "must be below alt_range_m");
    NEED(0 <= c->telemetry.dest16 && c->telemetry.dest16 <= 0xFFFF, "telemetry.dest16", "must be a 16-bit address");
    NEED(!c->telemetry.enable || c->ports.telemetry.present, "ports.telemetry", "missing (telemetry.enable is true)");
    NEED(c->kf.ground_effect_r_scale >= 1.0f, "kf.ground_effect_r_scale",
         "must be >= 1 (1 = no ground-effect allowance; got %s)", num(c->kf.ground_effect_r_scale, false, b, sizeof b));
    NEED(c->failsafe.imu_timeout_s > cfg_T_s(c), "failsafe.imu_timeout_s", "must be longer than one sample period");
    NEED(0.0f < c->modes.landed_collective_ratio && c->modes.landed_collective_ratio < 1.0f,
         "modes.landed_collective_ratio",
         "must be between 0 and 1 (a fraction of the hover collective; got %s)",
         num(c->modes.landed_collective_ratio, false, b, sizeof b));
    return true;
}

bool cfg_parse(const char *text, size_t len, const char *file, fc_config_t *cfg, cfg_error_t *err)
{
    apply_t a;
    char why[200];
    memset(err, 0, sizeof *err);
    snprintf(err->file, sizeof err->file, "%s", file);
    cfg_defaults(cfg);
    memset(&a, 0, sizeof a);
    a.cfg = cfg;
    a.err = err;
    if (!toml_parse(text, len, on_value, &a, why, sizeof why)) {
        if (!err->reason[0]) {
            err->key[0] = '\0';
            snprintf(err->reason, sizeof err->reason, "not valid TOML: %s", why);
        }
        return false;
    }
    if (!a.seen_ports)
        return error(err, "ports", "missing (a table is required)");
    for (int i = 0; i < 5; i++) {
        cfg_port_t *p = i == 0 ? &cfg->ports.imu : i == 1 ? &cfg->ports.adc : i == 2 ? &cfg->ports.rc
                      : i == 3 ? &cfg->ports.esc : &cfg->ports.telemetry;
        char key[40];
        if (!a.seen_port[i]) {
            if (i == 4)
                continue; /* telemetry may be left out */
            snprintf(key, sizeof key, "ports.%s", port_names[i]);
            return error(err, key, "missing (a table is required)");
        }
        p->present = true;
        snprintf(key, sizeof key, "ports.%s.path", port_names[i]);
        if (!a.seen_path[i])
            return error(err, key, "missing (a string is required)");
        snprintf(key, sizeof key, "ports.%s.baud", port_names[i]);
        if (!a.seen_baud[i])
            return error(err, key, "missing (an integer is required)");
    }
    return check(cfg, err);
}
