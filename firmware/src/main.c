/*
 * The flight code's entry point, as python -m flightcode (docs/flightcode.md):
 *
 *   fc --config FILE                 fly
 *   fc --config FILE --check-config  validate only: one JSON line, exit 0 or 2
 *
 * Exit status: 0 stopped by SIGTERM/SIGINT (motors to minimum first); 1 internal error;
 * 2 config missing or invalid (file, dotted key, reason); 3 a device could not be opened or
 * did not answer at boot (named). The lpc2148 build has no command line: it flies the config
 * compiled into the image (FW_EMBEDDED_CONFIG) and never returns.
 */
#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "config.h"
#include "hal.h"
#include "log.h"
#include "loop.h"

enum { EXIT_OK = 0, EXIT_INTERNAL = 1, EXIT_CONFIG = 2, EXIT_DEVICE = 3 };

static fc_config_t g_cfg;
static flight_loop_t g_loop;

static void fill_hal_config(const fc_config_t *c, hal_config_t *h)
{
    const cfg_port_t *ports[HAL_DEV_COUNT] = {&c->ports.imu, &c->ports.adc, &c->ports.rc, &c->ports.esc,
                                              &c->ports.telemetry};
    memset(h, 0, sizeof *h);
    for (int i = 0; i < HAL_DEV_COUNT; i++) {
        h->port[i].path = ports[i]->path;
        h->port[i].baud = (uint32_t)ports[i]->baud;
        h->port[i].enabled = ports[i]->present;
    }
    h->port[HAL_DEV_TELEMETRY].enabled = c->telemetry.enable && c->ports.telemetry.present;
    h->rc_frontend = c->rc.frontend == CFG_RC_SBUS ? HAL_RC_SBUS : HAL_RC_CAPTURE;
    h->spi_speed_hz = (uint32_t)c->adc.spi_speed_hz;
    h->adc_read_timeout_ns = (uint64_t)cfg_ns(c->adc.read_timeout_s);
    h->adc_reply_timeout_ns = (uint64_t)cfg_ns(c->adc.reply_timeout_s);
    h->adc_quiet_ns = (uint64_t)cfg_ns(c->adc.quiet_s);
    h->adc_resync_interval_ns = (uint64_t)cfg_ns(c->adc.resync_interval_s);
    h->adc_entry_attempts = (uint32_t)c->adc.entry_attempts;
    h->esc_first_channel = (uint8_t)c->esc.first_channel;
}

static void config_invalid(const cfg_error_t *err)
{
    if (log_begin(LOG_ERROR, "config.invalid")) {
        log_str("file", err->file);
        log_str("key", err->key);
        log_str("reason", err->reason);
        log_end();
    }
    if (err->key[0])
        fprintf(stderr, "firmware: invalid config: %s: %s: %s\n", err->file, err->key, err->reason);
    else
        fprintf(stderr, "firmware: invalid config: %s: %s\n", err->file, err->reason);
}

static void device_failed(hal_dev_t dev, const char *reason)
{
    if (log_begin(LOG_ERROR, "boot.failed")) {
        log_str("device", hal_dev_name(dev));
        log_str("reason", reason);
        log_end();
    }
    fprintf(stderr, "firmware: device '%s' failed at boot: %s\n", hal_dev_name(dev), reason);
}

/* Fly cfg until a stop request; the exit status. */
static int fly(const fc_config_t *cfg)
{
    hal_config_t hc;
    hal_dev_t failed = HAL_DEV_IMU;
    static cfg_error_t err;
    static char why[300];
    memset(&err, 0, sizeof err);
    log_set_level((log_level_t)cfg->log.level);
    if (cfg->rc.frontend == CFG_RC_SBUS && cfg->ports.rc.baud != 100000 && log_begin(LOG_WARNING, "config.sbus_baud")) {
        log_int("baud", cfg->ports.rc.baud);
        log_int("expected", 100000);
        log_end();
    }
    if (!loop_init(&g_loop, cfg, &err)) {
        config_invalid(&err);
        return EXIT_CONFIG;
    }
    fill_hal_config(cfg, &hc);
    if (hal_open(&hc, &failed) < 0) {
        device_failed(failed, hal_last_error());
        return EXIT_DEVICE;
    }
    if (log_begin(LOG_INFO, "ports.open")) {
        for (int i = 0; i < HAL_DEV_COUNT; i++)
            if (hc.port[i].enabled)
                log_str(hal_dev_name((hal_dev_t)i), hc.port[i].path);
        log_end();
    }
    if (loop_boot(&g_loop, &failed, why, sizeof why) < 0) {
        device_failed(failed, why);
        loop_shutdown(&g_loop);
        hal_close();
        return EXIT_DEVICE;
    }
    while (!hal_stop_requested())
        loop_step(&g_loop);
    if (log_begin(LOG_INFO, "signal")) {
        log_str("name", hal_stop_signal());
        log_end();
    }
    loop_shutdown(&g_loop);
    hal_close();
    return EXIT_OK;
}

#ifdef FW_EMBEDDED_CONFIG

extern const char fw_flight_config_text[];
extern const unsigned fw_flight_config_text_len;
extern const char fw_flight_config_text_name[];

int main(void)
{
    cfg_error_t err;
    if (!cfg_parse(fw_flight_config_text, fw_flight_config_text_len, fw_flight_config_text_name, &g_cfg, &err)) {
        config_invalid(&err);
        return EXIT_CONFIG;
    }
    return fly(&g_cfg);
}

#else

static int usage(void)
{
    fprintf(stderr, "usage: fc --config FILE [--check-config]\n");
    return EXIT_CONFIG;
}

/* The config text of path (malloc'd, NUL-terminated); NULL with err set. */
static char *read_file(const char *path, size_t *len, cfg_error_t *err)
{
    FILE *f = fopen(path, "rb");
    char *text;
    long size;
    memset(err, 0, sizeof *err);
    snprintf(err->file, sizeof err->file, "%s", path);
    if (!f) {
        snprintf(err->reason, sizeof err->reason, "cannot read: %s", strerror(errno));
        return NULL;
    }
    if (fseek(f, 0, SEEK_END) != 0 || (size = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        snprintf(err->reason, sizeof err->reason, "cannot read: %s", strerror(errno));
        fclose(f);
        return NULL;
    }
    text = malloc((size_t)size + 1);
    if (!text || fread(text, 1, (size_t)size, f) != (size_t)size) {
        snprintf(err->reason, sizeof err->reason, "cannot read: %s", text ? "short read" : "out of memory");
        free(text);
        fclose(f);
        return NULL;
    }
    fclose(f);
    text[size] = '\0';
    *len = (size_t)size;
    return text;
}

static void json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        if (*s == '"' || *s == '\\')
            printf("\\%c", *s);
        else if ((unsigned char)*s < 0x20)
            printf("\\u%04x", (unsigned char)*s);
        else
            putchar(*s);
    }
    putchar('"');
}

int main(int argc, char **argv)
{
    const char *path = NULL;
    bool check_only = false;
    cfg_error_t err;
    char *text;
    size_t len = 0;
    bool ok;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--config") && i + 1 < argc)
            path = argv[++i];
        else if (!strncmp(argv[i], "--config=", 9))
            path = argv[i] + 9;
        else if (!strcmp(argv[i], "--check-config"))
            check_only = true;
        else
            return usage();
    }
    if (!path)
        return usage();
    text = read_file(path, &len, &err);
    ok = text && cfg_parse(text, len, path, &g_cfg, &err);
    free(text);
    if (ok) /* the build's design must be this config's too */
        ok = loop_init(&g_loop, &g_cfg, &err);
    if (check_only) {
        if (ok) {
            printf("{\"flightcode_check\": 1, \"ok\": true}\n");
        } else {
            printf("{\"flightcode_check\": 1, \"ok\": false, \"file\": ");
            json_string(err.file);
            printf(", \"key\": ");
            json_string(err.key);
            printf(", \"reason\": ");
            json_string(err.reason);
            printf("}\n");
        }
        return ok ? EXIT_OK : EXIT_CONFIG;
    }
    if (!ok) {
        config_invalid(&err);
        return EXIT_CONFIG;
    }
    return fly(&g_cfg);
}

#endif
