/*
 * A flight code in another language, as far as the clock shim is concerned: it reads the
 * clocks and waits with timeouts through the C library, and prints what it saw.
 * Usage: client PTY_PATH. Each line: "<what> <value>"; times in ns.
 */
#define _GNU_SOURCE
#include <fcntl.h>
#include <poll.h>
#include <stdint.h>
#include <stdio.h>
#include <sys/epoll.h>
#include <sys/select.h>
#include <sys/time.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

static int64_t ns(clockid_t id) {
    struct timespec ts;
    clock_gettime(id, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

int main(int argc, char **argv) {
    if (argc < 2)
        return 2;
    int64_t t0 = ns(CLOCK_MONOTONIC);
    printf("monotonic %lld\n", (long long)t0);
    printf("realtime %lld\n", (long long)ns(CLOCK_REALTIME));
    printf("boottime %lld\n", (long long)ns(CLOCK_BOOTTIME));

    struct timespec req = {0, 250000000};
    nanosleep(&req, NULL);
    printf("nanosleep %lld\n", (long long)(ns(CLOCK_MONOTONIC) - t0));

    struct timespec abs;
    clock_gettime(CLOCK_MONOTONIC, &abs);
    abs.tv_nsec += 100000000;
    if (abs.tv_nsec >= 1000000000) {
        abs.tv_sec++;
        abs.tv_nsec -= 1000000000;
    }
    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &abs, NULL);
    printf("clock_nanosleep_abs %lld\n", (long long)(ns(CLOCK_MONOTONIC) - t0));

    int fd = open(argv[1], O_RDWR | O_NOCTTY);
    if (fd < 0)
        return 3;
    struct termios tio;
    tcgetattr(fd, &tio);
    cfmakeraw(&tio);
    tcsetattr(fd, TCSANOW, &tio);

    struct pollfd p = {.fd = fd, .events = POLLIN};
    int r = poll(&p, 1, 1000); /* the test writes at sim 0.5 s: well before this times out */
    char buf[64];
    ssize_t n = read(fd, buf, sizeof buf);
    printf("poll_data %d %lld %.*s\n", r, (long long)(ns(CLOCK_MONOTONIC) - t0), (int)(n > 0 ? n : 0), buf);

    r = poll(&p, 1, 200);
    printf("poll_timeout %d %lld\n", r, (long long)(ns(CLOCK_MONOTONIC) - t0));

    fd_set rfds;
    FD_ZERO(&rfds);
    FD_SET(fd, &rfds);
    struct timeval tv = {0, 300000};
    r = select(fd + 1, &rfds, NULL, NULL, &tv);
    printf("select_timeout %d %lld\n", r, (long long)(ns(CLOCK_MONOTONIC) - t0));

    int ep = epoll_create1(0);
    struct epoll_event ev = {.events = EPOLLIN, .data.fd = fd}, out;
    epoll_ctl(ep, EPOLL_CTL_ADD, fd, &ev);
    r = epoll_wait(ep, &out, 1, 150);
    printf("epoll_timeout %d %lld\n", r, (long long)(ns(CLOCK_MONOTONIC) - t0));

    usleep(1000);
    printf("usleep %lld\n", (long long)(ns(CLOCK_MONOTONIC) - t0));

    /* epoll hides its members from the shim: the bench makes it re-check after each write */
    r = epoll_wait(ep, &out, 1, 1000);
    n = read(fd, buf, sizeof buf);
    printf("epoll_data %d %lld %.*s\n", r, (long long)(ns(CLOCK_MONOTONIC) - t0), (int)(n > 0 ? n : 0), buf);

    struct timeval tod;
    gettimeofday(&tod, NULL);
    printf("gettimeofday %lld\n", (long long)tod.tv_sec * 1000000 + tod.tv_usec);

    /* CPU time passes through: burning CPU moves the thread CPU clock, not the monotonic one */
    int64_t c0 = ns(CLOCK_THREAD_CPUTIME_ID), m0 = ns(CLOCK_MONOTONIC);
    volatile uint64_t x = 0;
    for (uint64_t i = 0; i < 20000000; i++)
        x += i;
    printf("cpu_burn %lld %lld\n", (long long)(ns(CLOCK_THREAD_CPUTIME_ID) - c0), (long long)(ns(CLOCK_MONOTONIC) - m0));
    fflush(stdout);
    return 0;
}
