/*
 * The posix hardware layer: serial ports through termios (raw, exclusive, non-blocking),
 * CLOCK_MONOTONIC (virtual time under the bench's clock shim: its waits are ppoll and
 * nanosleep), SIGTERM/SIGINT as stop requests, log lines on stderr. The devices behind the
 * ports (Bus Pirate, capture front-end, Maestro) are in hal_posix_devices.c.
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/uio.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "hal.h"
#include "posix_port.h"

static struct {
    int fd[HAL_DEV_COUNT];
    char error[256];
    volatile sig_atomic_t stop_signal;
    bool handlers;
} g = {{-1, -1, -1, -1, -1}, "", 0, false};

const char *hal_dev_name(hal_dev_t dev)
{
    static const char *const names[HAL_DEV_COUNT] = {"imu", "adc", "rc", "esc", "telemetry"};
    return (unsigned)dev < HAL_DEV_COUNT ? names[dev] : "?";
}

int posix_fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(g.error, sizeof g.error, fmt, ap);
    va_end(ap);
    return HAL_ERR_IO;
}

const char *hal_last_error(void) { return g.error; }

/* -- signals ------------------------------------------------------------------------------- */

static void on_signal(int sig) { g.stop_signal = sig; }

static void install_handlers(void)
{
    struct sigaction sa;
    if (g.handlers)
        return;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal; /* no SA_RESTART: a blocked read returns and the loop sees the stop */
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    g.handlers = true;
}

bool hal_stop_requested(void) { return g.stop_signal != 0; }

const char *hal_stop_signal(void)
{
    switch (g.stop_signal) {
    case SIGTERM: return "SIGTERM";
    case SIGINT: return "SIGINT";
    case 0: return "";
    default: return "signal";
    }
}

/* -- time -------------------------------------------------------------------------------------- */

uint64_t hal_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000ull + (uint64_t)ts.tv_nsec;
}

void hal_sleep_ns(uint64_t ns)
{
    struct timespec ts = {(time_t)(ns / 1000000000ull), (long)(ns % 1000000000ull)};
    while (nanosleep(&ts, &ts) < 0 && errno == EINTR && !hal_stop_requested()) {
    }
}

/* -- log ----------------------------------------------------------------------------------------- */

void hal_log_line(const char *line, size_t n)
{
    struct iovec iov[2] = {{(void *)line, n}, {(void *)"\n", 1}};
    ssize_t r = writev(STDERR_FILENO, iov, 2);
    (void)r;
}

/* -- serial ports -------------------------------------------------------------------------------- */

static speed_t standard_speed(uint32_t baud)
{
    switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 500000: return B500000;
    case 921600: return B921600;
    case 1000000: return B1000000;
    default: return 0;
    }
}

static int open_port(hal_dev_t dev, const hal_port_config_t *pc, bool sbus)
{
    struct termios tio;
    speed_t speed = standard_speed(pc->baud);
    int fd = open(pc->path, O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0)
        return posix_fail("cannot open %s at %u bit/s: %s", pc->path, (unsigned)pc->baud, strerror(errno));
    if (ioctl(fd, TIOCEXCL) < 0 || tcgetattr(fd, &tio) < 0) {
        int e = errno;
        close(fd);
        return posix_fail("cannot open %s at %u bit/s: %s", pc->path, (unsigned)pc->baud, strerror(e));
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cflag &= ~(tcflag_t)(CSTOPB | PARENB | PARODD | CRTSCTS);
    if (sbus)
        tio.c_cflag |= PARENB | CSTOPB; /* 8E2 */
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    if (speed) {
        cfsetispeed(&tio, speed);
        cfsetospeed(&tio, speed);
    }
    if (tcsetattr(fd, TCSANOW, &tio) < 0 || (!speed && posix_set_custom_baud(fd, pc->baud) < 0)) {
        int e = errno;
        close(fd);
        return posix_fail("cannot open %s at %u bit/s: %s", pc->path, (unsigned)pc->baud, strerror(e));
    }
    g.fd[dev] = fd;
    return HAL_OK;
}

int hal_open(const hal_config_t *cfg, hal_dev_t *failed)
{
    static const hal_dev_t order[HAL_DEV_COUNT] = {HAL_DEV_IMU, HAL_DEV_ADC, HAL_DEV_RC, HAL_DEV_ESC,
                                                   HAL_DEV_TELEMETRY};
    install_handlers();
    for (int i = 0; i < HAL_DEV_COUNT; i++) {
        hal_dev_t dev = order[i];
        int r;
        if (!cfg->port[dev].enabled)
            continue;
        r = open_port(dev, &cfg->port[dev], dev == HAL_DEV_RC && cfg->rc_frontend == HAL_RC_SBUS);
        if (r < 0) {
            *failed = dev;
            hal_close();
            return r;
        }
    }
    posix_devices_open(cfg);
    return HAL_OK;
}

void hal_close(void)
{
    posix_devices_close();
    for (int i = 0; i < HAL_DEV_COUNT; i++) {
        if (g.fd[i] >= 0)
            close(g.fd[i]);
        g.fd[i] = -1;
    }
}

int posix_port_fd(hal_dev_t dev) { return (unsigned)dev < HAL_DEV_COUNT ? g.fd[dev] : -1; }

static int32_t io_error(hal_dev_t dev, const char *what)
{
    posix_fail("%s %s: %s", what, hal_dev_name(dev), strerror(errno));
    return HAL_ERR_IO;
}

int32_t posix_port_read(hal_dev_t dev, uint8_t *buf, size_t max, uint64_t timeout_ns)
{
    int fd = posix_port_fd(dev);
    ssize_t n;
    if (fd < 0)
        return HAL_ERR_ABSENT;
    if (max == 0)
        return 0;
    if (timeout_ns > 0) {
        /* a caller that may wait expects nothing yet (the next sample, a reply): wait first,
         * rather than spend a read on EAGAIN every sample */
        struct pollfd pfd = {fd, POLLIN, 0};
        struct timespec ts = {(time_t)(timeout_ns / 1000000000ull), (long)(timeout_ns % 1000000000ull)};
        int r;
        if (hal_stop_requested())
            return 0;
        r = ppoll(&pfd, 1, &ts, NULL);
        if (r < 0)
            return errno == EINTR ? 0 : io_error(dev, "cannot wait on");
        if (r == 0)
            return 0;
        if (pfd.revents & (POLLERR | POLLNVAL)) {
            errno = EIO;
            return io_error(dev, "cannot read");
        }
    }
    n = read(fd, buf, max);
    if (n > 0)
        return (int32_t)n;
    if (n < 0 && errno != EAGAIN && errno != EINTR)
        return io_error(dev, "cannot read");
    if (n == 0 && timeout_ns > 0) { /* readable yet no data: the other end hung up */
        posix_fail("%s reports readiness to read but returned no data (device disconnected?)", hal_dev_name(dev));
        return HAL_ERR_IO;
    }
    return 0;
}

int32_t posix_port_write(hal_dev_t dev, const uint8_t *data, size_t n)
{
    int fd = posix_port_fd(dev);
    ssize_t w;
    if (fd < 0)
        return HAL_ERR_ABSENT;
    w = write(fd, data, n);
    if (w >= 0)
        return (int32_t)w;
    if (errno == EAGAIN || errno == EINTR)
        return 0;
    return io_error(dev, "cannot write");
}

/* A byte count the tty layer keeps for the port (FIONREAD: received; TIOCOUTQ: not yet sent). */
static int32_t port_queue_count(hal_dev_t dev, unsigned long request)
{
    int fd = posix_port_fd(dev), n = 0;
    if (fd < 0)
        return HAL_ERR_ABSENT;
    if (ioctl(fd, request, &n) < 0)
        return io_error(dev, "cannot query");
    return n;
}

int32_t posix_port_in_waiting(hal_dev_t dev)
{
    return port_queue_count(dev, FIONREAD);
}

int32_t posix_port_out_waiting(hal_dev_t dev)
{
    return port_queue_count(dev, TIOCOUTQ);
}

void posix_port_flush_input(hal_dev_t dev)
{
    int fd = posix_port_fd(dev);
    if (fd >= 0)
        tcflush(fd, TCIFLUSH);
}

/* -- the UARTs of hal.h ------------------------------------------------------------------------- */

static hal_dev_t uart_dev(hal_uart_t uart)
{
    switch (uart) {
    case HAL_UART_IMU: return HAL_DEV_IMU;
    case HAL_UART_TELEMETRY: return HAL_DEV_TELEMETRY;
    case HAL_UART_RC: return HAL_DEV_RC;
    default: return HAL_DEV_COUNT;
    }
}

int32_t hal_uart_read(hal_uart_t uart, uint8_t *buf, size_t max, uint64_t timeout_ns)
{
    return posix_port_read(uart_dev(uart), buf, max, timeout_ns);
}

int32_t hal_uart_write(hal_uart_t uart, const uint8_t *data, size_t n)
{
    return posix_port_write(uart_dev(uart), data, n);
}

int32_t hal_uart_in_waiting(hal_uart_t uart) { return posix_port_in_waiting(uart_dev(uart)); }
int32_t hal_uart_out_waiting(hal_uart_t uart) { return posix_port_out_waiting(uart_dev(uart)); }
void hal_uart_flush_input(hal_uart_t uart) { posix_port_flush_input(uart_dev(uart)); }
