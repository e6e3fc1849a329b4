/* The posix layer's serial ports (termios), shared by its files. */
#ifndef FW_POSIX_PORT_H
#define FW_POSIX_PORT_H

#include <stddef.h>
#include <stdint.h>

#include "hal.h"

/* The layer's ports, one per device (the RC port carries capture records or SBUS). */
int posix_port_fd(hal_dev_t dev);
int32_t posix_port_read(hal_dev_t dev, uint8_t *buf, size_t max, uint64_t timeout_ns);
int32_t posix_port_write(hal_dev_t dev, const uint8_t *data, size_t n);
int32_t posix_port_in_waiting(hal_dev_t dev);
int32_t posix_port_out_waiting(hal_dev_t dev);
void posix_port_flush_input(hal_dev_t dev);
/* Sets the error text hal_last_error returns; returns HAL_ERR_IO. */
int posix_fail(const char *fmt, ...);

/* A custom line rate through termios2 (BOTHER); 0 or -1 with errno. */
int posix_set_custom_baud(int fd, uint32_t baud);

/* The devices of hal_posix_devices.c: set up at hal_open, torn down at hal_close. */
int posix_devices_open(const hal_config_t *cfg);
void posix_devices_close(void);
hal_counters_t *posix_counters(void);

#endif
