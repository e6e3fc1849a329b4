/*
 * The clock shim: preloaded (LD_PRELOAD) into every process of the flight command in lockstep
 * runs so that its clocks, sleeps and I/O-wait timeouts run on the bench's sim time.
 *
 * See docs/time.md. In short:
 *  - clock_gettime/gettimeofday/time/timespec_get read sim time from the control block
 *    (hvt_abi.h). CPU-time clocks pass through.
 *  - Every wait with a timeout (nanosleep, clock_nanosleep, usleep, sleep, select, pselect,
 *    poll, ppoll, epoll_wait, epoll_pwait, epoll_pwait2) first checks its fds without
 *    blocking; if nothing is ready it publishes "blocked until <deadline> on <these
 *    devices>" in its thread's slot, tells the bench (one byte on the notify FIFO) and
 *    waits on its fds plus its slot's wake FIFO, with no host timeout. Only the bench ends
 *    the wait early by time: it writes the wake FIFO once sim time has reached the deadline.
 *  - A thread that reads a virtual clock spin_limit times without blocking is busy-waiting
 *    on it; it is granted spin_quantum_ns of sim time as if it had slept.
 *  - Waits that another process of the flight command's tree ends (wait, waitpid, wait3,
 *    wait4, waitid; read/readv on a descriptor with nothing to read) publish "blocked, ask
 *    the kernel" in the slot only when the real call will sleep; the bench confirms the
 *    sleep in /proc, as for a lock.
 *  - Futex waits with absolute deadlines (pthread_cond_timedwait, sem_timedwait, ...) cannot
 *    wait on the wake FIFO: their deadlines are translated to the host clock and the call is
 *    counted as uncovered, so the bench can warn.
 *  - When the bench goes away (the wake FIFO hangs up) or ends the run (mode FREE_RUN), the
 *    clocks continue from sim time at the host's rate and waits use host timeouts.
 *
 * Without HIL_VT_CTL in the environment, everything passes straight through.
 */
#define _GNU_SOURCE
#undef _FORTIFY_SOURCE /* its inline wrappers of poll/select would clash with ours */
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <semaphore.h>
#include <signal.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <sys/time.h>
#include <sys/timerfd.h>
#include <sys/resource.h>
#include <sys/uio.h>
#include <sys/wait.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "hvt_abi.h"

_Static_assert(sizeof(struct hvt_header) == 344, "header layout changed: update abi.py");
_Static_assert(sizeof(struct hvt_slot) == 128, "slot layout changed: update abi.py");

#define EXPORT __attribute__((visibility("default")))
#define TLS __thread __attribute__((tls_model("initial-exec")))
#define NS_PER_S 1000000000LL
#define STACK_FDS 64

/* What the Python side checks against its mirror (tests/unit/vtime/test_abi.py). */
EXPORT const uint32_t hvt_abi_layout[] = {
    HVT_MAGIC, HVT_VERSION, HVT_MAX_THREADS, HVT_MAX_KEYS, HVT_N_CALLS,
    sizeof(struct hvt_header), sizeof(struct hvt_slot),
    offsetof(struct hvt_header, time_seq), offsetof(struct hvt_header, now_ns),
    offsetof(struct hvt_header, free_run_host_ns), offsetof(struct hvt_header, epoch),
    offsetof(struct hvt_header, calls),
    offsetof(struct hvt_slot, seq), offsetof(struct hvt_slot, deadline_ns),
    offsetof(struct hvt_slot, cpu_ns), offsetof(struct hvt_slot, nkeys),
    offsetof(struct hvt_slot, key_rdev), offsetof(struct hvt_slot, key_events),
    offsetof(struct hvt_slot, clock_reads), offsetof(struct hvt_slot, wait_kind),
    offsetof(struct hvt_slot, wait_pid),
};

/* ---- the real functions --------------------------------------------------------------- */

typedef int (*clock_gettime_fn)(clockid_t, struct timespec *);
typedef int (*ppoll_fn)(struct pollfd *, nfds_t, const struct timespec *, const sigset_t *);
typedef int (*select_fn)(int, fd_set *, fd_set *, fd_set *, struct timeval *);
typedef int (*pselect_fn)(int, fd_set *, fd_set *, fd_set *, const struct timespec *, const sigset_t *);
typedef int (*poll_fn)(struct pollfd *, nfds_t, int);
typedef int (*nanosleep_fn)(const struct timespec *, struct timespec *);
typedef int (*clock_nanosleep_fn)(clockid_t, int, const struct timespec *, struct timespec *);
typedef int (*epoll_wait_fn)(int, struct epoll_event *, int, int);
typedef int (*epoll_pwait_fn)(int, struct epoll_event *, int, int, const sigset_t *);
typedef int (*epoll_pwait2_fn)(int, struct epoll_event *, int, const struct timespec *, const sigset_t *);
typedef int (*gettimeofday_fn)(struct timeval *, void *);
typedef time_t (*time_fn)(time_t *);
typedef int (*timespec_get_fn)(struct timespec *, int);
typedef int (*usleep_fn)(useconds_t);
typedef unsigned (*sleep_fn)(unsigned);
typedef int (*timerfd_create_fn)(int, int);
typedef int (*timer_create_fn)(clockid_t, struct sigevent *, timer_t *);
typedef int (*setitimer_fn)(__itimer_which_t, const struct itimerval *, struct itimerval *);
typedef unsigned (*alarm_fn)(unsigned);
typedef int (*cond_timedwait_fn)(pthread_cond_t *, pthread_mutex_t *, const struct timespec *);
typedef int (*cond_clockwait_fn)(pthread_cond_t *, pthread_mutex_t *, clockid_t, const struct timespec *);
typedef int (*sem_timedwait_fn)(sem_t *, const struct timespec *);
typedef int (*sem_clockwait_fn)(sem_t *, clockid_t, const struct timespec *);
typedef int (*mutex_timedlock_fn)(pthread_mutex_t *, const struct timespec *);
typedef pid_t (*wait4_fn)(pid_t, int *, int, struct rusage *);
typedef int (*waitid_fn)(idtype_t, id_t, siginfo_t *, int);
typedef ssize_t (*read_fn)(int, void *, size_t);
typedef ssize_t (*readv_fn)(int, const struct iovec *, int);
typedef ssize_t (*read_chk_fn)(int, void *, size_t, size_t);

static void *real_sym(const char *name, const char *version) {
    void *p = NULL;
    if (version)
        p = dlvsym(RTLD_NEXT, name, version);
    if (!p)
        p = dlsym(RTLD_NEXT, name);
    return p;
}

/* Resolved on first use: other libraries' constructors may call us before ours runs. */
#define REAL(name, type) REAL_V(name, type, NULL)
#define REAL_V(name, type, version)                                                            \
    static type real_##name;                                                                   \
    if (!real_##name)                                                                          \
        real_##name = (type)real_sym(#name, version);

/* ---- state ---------------------------------------------------------------------------- */

static struct hvt_header *H;     /* NULL: pass everything through */
static struct hvt_slot *SLOTS;
static char ctl_path[4096];
static int notify_fd = -1;
static pthread_key_t slot_key;

/* The bench went away without ending the run: free-run from here (per process). */
static volatile int gone;
static int64_t gone_virtual_ns, gone_host_ns;

static TLS struct hvt_slot *tl_slot;
static TLS int tl_wake_fd = -1;
static TLS int tl_claim; /* 0 not tried, 1 have a slot, 2 none free */

static int64_t host_mono_ns(void) {
    REAL(clock_gettime, clock_gettime_fn);
    struct timespec ts;
    real_clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec * NS_PER_S + ts.tv_nsec;
}

static int64_t ts_ns(const struct timespec *ts) { return ts->tv_sec * NS_PER_S + ts->tv_nsec; }

static struct timespec ns_ts(int64_t ns) {
    struct timespec ts;
    if (ns < 0)
        ns = 0;
    ts.tv_sec = ns / NS_PER_S;
    ts.tv_nsec = ns % NS_PER_S;
    return ts;
}

static void count(int call) {
    if (H)
        __atomic_fetch_add(&H->calls[call], 1, __ATOMIC_RELAXED);
}

static uint32_t load_u32(const uint32_t *p) { return __atomic_load_n(p, __ATOMIC_ACQUIRE); }

/* The bench's clock value (seqlock: the bench writes now_ns between two time_seq bumps). */
static int64_t virtual_now(void) {
    for (;;) {
        uint32_t s1 = load_u32(&H->time_seq);
        if (s1 & 1u) {
            sched_yield();
            continue;
        }
        int64_t v = __atomic_load_n(&H->now_ns, __ATOMIC_RELAXED);
        __atomic_thread_fence(__ATOMIC_ACQUIRE);
        if (load_u32(&H->time_seq) == s1)
            return v;
    }
}

static int free_running(void) { return gone || load_u32(&H->mode) == HVT_MODE_FREE_RUN; }

/* The flight code's clock, ns since its start. */
static int64_t vt_now(void) {
    if (gone)
        return gone_virtual_ns + (host_mono_ns() - gone_host_ns);
    if (load_u32(&H->mode) == HVT_MODE_FREE_RUN)
        return virtual_now() + (host_mono_ns() - __atomic_load_n(&H->free_run_host_ns, __ATOMIC_ACQUIRE));
    return virtual_now();
}

static void bench_gone(void) {
    if (!gone) {
        gone_virtual_ns = vt_now();
        gone_host_ns = host_mono_ns();
        gone = 1;
    }
}

/* ---- clocks ---------------------------------------------------------------------------- */

enum kind { K_MONO, K_REAL, K_TAI, K_CPU, K_OTHER };

static enum kind clock_kind(clockid_t id) {
    switch (id) {
    case CLOCK_MONOTONIC:
    case CLOCK_MONOTONIC_RAW:
    case CLOCK_MONOTONIC_COARSE:
    case CLOCK_BOOTTIME:
    case CLOCK_BOOTTIME_ALARM:
        return K_MONO;
    case CLOCK_REALTIME:
    case CLOCK_REALTIME_COARSE:
    case CLOCK_REALTIME_ALARM:
        return K_REAL;
    case CLOCK_TAI:
        return K_TAI;
    case CLOCK_PROCESS_CPUTIME_ID:
    case CLOCK_THREAD_CPUTIME_ID:
        return K_CPU;
    default:
        /* Negative ids encode CPU clocks of other processes/threads (low bits 0-2) and
         * dynamic posix clocks on an fd (low bits 3). */
        if (id < 0 && (id & 7) != 3)
            return K_CPU;
        return K_OTHER;
    }
}

static int64_t clock_base(enum kind k) {
    switch (k) {
    case K_MONO:
        return H->mono_base_ns;
    case K_REAL:
        return H->real_base_ns;
    default:
        return H->real_base_ns + H->tai_offset_ns;
    }
}

static int virtual_kind(enum kind k) { return k == K_MONO || k == K_REAL || k == K_TAI; }

/* ---- slots ----------------------------------------------------------------------------- */

static void release_slot(void *unused) {
    (void)unused;
    if (tl_slot) {
        if (tl_wake_fd >= 0)
            close(tl_wake_fd);
        tl_wake_fd = -1;
        __atomic_store_n(&tl_slot->state, HVT_FREE, __ATOMIC_RELEASE);
        __atomic_store_n(&tl_slot->tid, 0, __ATOMIC_RELEASE);
        tl_slot = NULL;
    }
}

static int open_wake_fd(int index) {
    char path[4200];
    snprintf(path, sizeof path, "%s.w%02d", ctl_path, index);
    return open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
}

static void drain(int fd) {
    REAL(read, read_fn); /* not our read(): a wake FIFO is never a wait of the flight code */
    char buf[64];
    while (real_read(fd, buf, sizeof buf) > 0) {
    }
}

static struct hvt_slot *claim(int reserved_index);

static struct hvt_slot *my_slot(void) {
    if (tl_claim == 1)
        return tl_slot;
    if (tl_claim == 2 || !H)
        return NULL;
    return claim(-1);
}

/* Take a slot for the calling thread: the one its creator reserved, the one it had before
 * an exec, or a free one. */
static struct hvt_slot *claim(int reserved_index) {
    int32_t tid = (int32_t)syscall(SYS_gettid), pid = getpid();
    struct hvt_slot *found = NULL;
    int index = -1;
    if (reserved_index >= 0) {
        found = &SLOTS[reserved_index];
        index = reserved_index;
        __atomic_store_n(&found->tid, tid, __ATOMIC_RELEASE);
    }
    /* The same thread after an exec keeps its slot. */
    for (int i = 0; i < HVT_MAX_THREADS && !found; i++)
        if (__atomic_load_n(&SLOTS[i].tid, __ATOMIC_ACQUIRE) == tid && SLOTS[i].pid == pid)
            found = &SLOTS[i], index = i;
    for (int i = 0; i < HVT_MAX_THREADS && !found; i++) {
        int32_t expected = 0;
        if (__atomic_compare_exchange_n(&SLOTS[i].tid, &expected, tid, 0, __ATOMIC_ACQ_REL, __ATOMIC_RELAXED))
            found = &SLOTS[i], index = i;
    }
    if (!found) {
        tl_claim = 2;
        count(HVT_CALL_NO_SLOT);
        return NULL;
    }
    /* The bench reads tid before pid: name the process at once (it judges a slot by its
     * thread, so the moment the old pid still shows does no harm, but it is kept short). */
    __atomic_store_n(&found->pid, pid, __ATOMIC_RELEASE);
    int fd = open_wake_fd(index);
    if (fd < 0) {
        __atomic_store_n(&found->tid, 0, __ATOMIC_RELEASE);
        tl_claim = 2;
        count(HVT_CALL_NO_SLOT);
        return NULL;
    }
    drain(fd);
    found->clock_reads = 0;
    uint32_t seq = __atomic_load_n(&found->seq, __ATOMIC_RELAXED);
    if (seq & 1u)
        seq++;
    __atomic_store_n(&found->state, HVT_RUNNING, __ATOMIC_RELEASE);
    __atomic_store_n(&found->seq, seq, __ATOMIC_RELEASE);
    tl_slot = found;
    tl_wake_fd = fd;
    tl_claim = 1;
    pthread_setspecific(slot_key, found); /* the destructor frees it when the thread ends */
    return found;
}

static int64_t thread_cpu_ns(void) {
    REAL(clock_gettime, clock_gettime_fn);
    struct timespec ts;
    real_clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return ts_ns(&ts);
}

static void publish_blocked(struct hvt_slot *s, const struct pollfd *fds, nfds_t n, int64_t deadline,
                            uint32_t epoch, int unknown, uint32_t kind) {
    s->wait_kind = kind;
    s->deadline_ns = deadline;
    s->seen_epoch = epoch;
    s->cpu_ns = thread_cpu_ns();
    s->blocks++;
    s->clock_reads = 0;
    uint32_t k = 0;
    if (unknown) {
        k = HVT_KEYS_UNKNOWN;
    } else {
        for (nfds_t i = 0; i < n; i++) {
            struct stat st;
            if (fds[i].fd < 0 || fstat(fds[i].fd, &st) != 0 || !S_ISCHR(st.st_mode))
                continue;
            if (k == HVT_MAX_KEYS) {
                k = HVT_KEYS_UNKNOWN;
                break;
            }
            s->key_rdev[k] = (major(st.st_rdev) << 20) | minor(st.st_rdev);
            s->key_events[k] = (uint16_t)fds[i].events;
            k++;
        }
    }
    s->nkeys = k;
    __atomic_store_n(&s->state, HVT_BLOCKED, __ATOMIC_RELEASE);
    __atomic_store_n(&s->seq, s->seq + 1, __ATOMIC_RELEASE);
}

static void notify_bench(void) {
    if (notify_fd >= 0) {
        ssize_t w = write(notify_fd, "b", 1);
        (void)w; /* a full FIFO already holds a wake-up for the bench */
    }
}

static void publish_running(struct hvt_slot *s) {
    __atomic_store_n(&s->state, HVT_RUNNING, __ATOMIC_RELEASE);
    __atomic_store_n(&s->seq, s->seq + 1, __ATOMIC_RELEASE);
}

/* A wait the bench does not schedule: host timeouts from the remaining sim time. */
static int host_wait(struct pollfd *fds, nfds_t n, int64_t deadline, const sigset_t *mask) {
    REAL(ppoll, ppoll_fn);
    struct timespec ts, *tp = NULL;
    if (deadline != HVT_NO_DEADLINE) {
        ts = ns_ts(deadline - vt_now());
        tp = &ts;
    }
    return real_ppoll(fds, n, tp, mask);
}

/*
 * Wait until one of fds is ready (poll semantics, revents filled) or the flight code's
 * clock reaches deadline (returns 0). -1 with errno on error/EINTR. unknown: the wait set
 * is an epoll instance whose members the shim cannot name.
 */
static int vt_wait(struct pollfd *fds, nfds_t n, int64_t deadline, const sigset_t *mask, int unknown) {
    REAL(ppoll, ppoll_fn);
    struct hvt_slot *s = my_slot();
    if (!s || free_running())
        return host_wait(fds, n, deadline, mask);
    struct pollfd stack[STACK_FDS + 1], *all = stack;
    if (n + 1 > STACK_FDS + 1) {
        all = malloc((n + 1) * sizeof *all);
        if (!all) {
            errno = ENOMEM;
            return -1;
        }
    }
    static const struct timespec zero = {0, 0};
    int result;
    for (;;) {
        uint32_t epoch = load_u32(&H->epoch);
        if (n > 0) {
            result = real_ppoll(fds, n, &zero, NULL);
            if (result != 0)
                break;
        }
        if (deadline != HVT_NO_DEADLINE && vt_now() >= deadline) {
            result = 0;
            break;
        }
        if (free_running()) {
            result = host_wait(fds, n, deadline, mask);
            break;
        }
        publish_blocked(s, fds, n, deadline, epoch, unknown, HVT_WAIT_FD);
        notify_bench();
        memcpy(all, fds, n * sizeof *fds);
        all[n].fd = tl_wake_fd;
        all[n].events = POLLIN;
        all[n].revents = 0;
        int r = real_ppoll(all, n + 1, NULL, mask);
        int saved = errno;
        publish_running(s);
        if (r < 0) {
            errno = saved;
            result = -1;
            break;
        }
        short wake = all[n].revents;
        if (wake & (POLLHUP | POLLERR | POLLNVAL)) {
            bench_gone(); /* the bench closed the FIFO: it ended or died */
        } else if (wake & POLLIN) {
            drain(tl_wake_fd);
        }
        int ready = 0;
        for (nfds_t i = 0; i < n; i++) {
            fds[i].revents = all[i].revents;
            if (all[i].revents)
                ready++;
        }
        if (ready) {
            result = ready;
            break;
        }
        /* Woken by the bench: time advanced, a poke after new bytes, or the run ended.
         * The loop re-checks the fds, then the deadline. */
    }
    if (all != stack)
        free(all);
    return result;
}

static int64_t deadline_after(int64_t delta_ns) { return delta_ns < 0 ? HVT_NO_DEADLINE : vt_now() + delta_ns; }

/* A virtual-clock read outside any wait: count it towards busy-wait detection. */
static void clock_read(void) {
    struct hvt_slot *s = my_slot();
    /* Start-up (imports before any wait) is not a busy-wait, however often it reads the clock. */
    if (!s || !s->blocks || free_running() || !H->spin_limit)
        return;
    if (++s->clock_reads >= H->spin_limit) {
        count(HVT_CALL_SPIN_YIELD);
        s->spin_yields++;
        vt_wait(NULL, 0, vt_now() + H->spin_quantum_ns, NULL, 0);
    }
}

static int active(void) { return H != NULL && load_u32(&H->mode) != HVT_MODE_OFF; }

/* ---- clocks (interposed) --------------------------------------------------------------- */

EXPORT int clock_gettime(clockid_t id, struct timespec *ts) {
    REAL(clock_gettime, clock_gettime_fn);
    if (!active())
        return real_clock_gettime(id, ts);
    enum kind k = clock_kind(id);
    if (!virtual_kind(k)) {
        count(k == K_CPU ? HVT_CALL_CPU_CLOCK : HVT_CALL_CLOCK_OTHER);
        return real_clock_gettime(id, ts);
    }
    count(HVT_CALL_CLOCK_GETTIME);
    *ts = ns_ts(clock_base(k) + vt_now());
    clock_read();
    return 0;
}

EXPORT int gettimeofday(struct timeval *tv, void *tz) {
    REAL(gettimeofday, gettimeofday_fn);
    if (!active())
        return real_gettimeofday(tv, tz);
    count(HVT_CALL_GETTIMEOFDAY);
    int64_t ns = H->real_base_ns + vt_now();
    tv->tv_sec = ns / NS_PER_S;
    tv->tv_usec = (ns % NS_PER_S) / 1000;
    if (tz)
        memset(tz, 0, 2 * sizeof(int)); /* struct timezone: obsolete, zero like glibc */
    clock_read();
    return 0;
}

EXPORT time_t time(time_t *out) {
    REAL(time, time_fn);
    if (!active())
        return real_time(out);
    count(HVT_CALL_TIME);
    time_t t = (time_t)((H->real_base_ns + vt_now()) / NS_PER_S);
    if (out)
        *out = t;
    clock_read();
    return t;
}

EXPORT int timespec_get(struct timespec *ts, int base) {
    REAL(timespec_get, timespec_get_fn);
    if (!active() || base != TIME_UTC)
        return real_timespec_get(ts, base);
    count(HVT_CALL_TIMESPEC_GET);
    *ts = ns_ts(H->real_base_ns + vt_now());
    clock_read();
    return base;
}

/* ---- sleeps ---------------------------------------------------------------------------- */

static int valid_ts(const struct timespec *ts) { return ts && ts->tv_nsec >= 0 && ts->tv_nsec < NS_PER_S && ts->tv_sec >= 0; }

/* Sleep until deadline; 0, or -1/EINTR with *remaining_ns set. */
static int sleep_until(int64_t deadline, int64_t *remaining_ns) {
    int r = vt_wait(NULL, 0, deadline, NULL, 0);
    if (r < 0) {
        if (remaining_ns) {
            int64_t left = deadline - vt_now();
            *remaining_ns = left > 0 ? left : 0;
        }
        return -1;
    }
    return 0;
}

EXPORT int nanosleep(const struct timespec *req, struct timespec *rem) {
    REAL(nanosleep, nanosleep_fn);
    if (!active())
        return real_nanosleep(req, rem);
    count(HVT_CALL_NANOSLEEP);
    if (!valid_ts(req)) {
        errno = EINVAL;
        return -1;
    }
    int64_t left = 0;
    if (sleep_until(vt_now() + ts_ns(req), &left) < 0) {
        if (rem)
            *rem = ns_ts(left);
        return -1;
    }
    return 0;
}

EXPORT int clock_nanosleep(clockid_t id, int flags, const struct timespec *req, struct timespec *rem) {
    REAL(clock_nanosleep, clock_nanosleep_fn);
    if (!active())
        return real_clock_nanosleep(id, flags, req, rem);
    enum kind k = clock_kind(id);
    if (!virtual_kind(k)) {
        count(k == K_CPU ? HVT_CALL_CPU_CLOCK : HVT_CALL_CLOCK_OTHER);
        return real_clock_nanosleep(id, flags, req, rem);
    }
    count(HVT_CALL_CLOCK_NANOSLEEP);
    if (!req || req->tv_nsec < 0 || req->tv_nsec >= NS_PER_S)
        return EINVAL;
    int64_t deadline = (flags & TIMER_ABSTIME) ? ts_ns(req) - clock_base(k) : vt_now() + ts_ns(req);
    int64_t left = 0;
    if (sleep_until(deadline, &left) < 0) {
        int err = errno;
        if (rem && !(flags & TIMER_ABSTIME))
            *rem = ns_ts(left);
        return err;
    }
    return 0;
}

EXPORT int usleep(useconds_t us) {
    REAL(usleep, usleep_fn);
    if (!active())
        return real_usleep(us);
    count(HVT_CALL_USLEEP);
    return sleep_until(vt_now() + (int64_t)us * 1000, NULL);
}

EXPORT unsigned sleep(unsigned seconds) {
    REAL(sleep, sleep_fn);
    if (!active())
        return real_sleep(seconds);
    count(HVT_CALL_SLEEP);
    int64_t left = 0;
    if (sleep_until(vt_now() + (int64_t)seconds * NS_PER_S, &left) < 0)
        return (unsigned)((left + NS_PER_S - 1) / NS_PER_S);
    return 0;
}

/* ---- I/O waits ------------------------------------------------------------------------- */

EXPORT int poll(struct pollfd *fds, nfds_t n, int timeout_ms) {
    REAL(poll, poll_fn);
    if (!active())
        return real_poll(fds, n, timeout_ms);
    count(HVT_CALL_POLL);
    if (timeout_ms == 0) {
        clock_read(); /* a polling loop is a busy-wait too */
        return real_poll(fds, n, 0);
    }
    return vt_wait(fds, n, deadline_after(timeout_ms < 0 ? -1 : (int64_t)timeout_ms * 1000000), NULL, 0);
}

EXPORT int ppoll(struct pollfd *fds, nfds_t n, const struct timespec *tmo, const sigset_t *mask) {
    REAL(ppoll, ppoll_fn);
    if (!active())
        return real_ppoll(fds, n, tmo, mask);
    count(HVT_CALL_PPOLL);
    if (tmo && !valid_ts(tmo)) {
        errno = EINVAL;
        return -1;
    }
    if (tmo && ts_ns(tmo) == 0) {
        clock_read();
        return real_ppoll(fds, n, tmo, mask);
    }
    return vt_wait(fds, n, tmo ? vt_now() + ts_ns(tmo) : HVT_NO_DEADLINE, mask, 0);
}

/* select/pselect: wait in poll form, then let the real call fill the sets. */
static int select_wait(int nfds, fd_set *r, fd_set *w, fd_set *e, int64_t deadline, const sigset_t *mask,
                       int64_t *left_ns) {
    REAL(pselect, pselect_fn);
    struct pollfd stack[STACK_FDS], *pfds = stack;
    if (nfds < 0 || nfds > FD_SETSIZE) {
        errno = EINVAL;
        return -1;
    }
    int k = 0;
    for (int fd = 0; fd < nfds; fd++)
        if ((r && FD_ISSET(fd, r)) || (w && FD_ISSET(fd, w)) || (e && FD_ISSET(fd, e)))
            k++;
    if (k > STACK_FDS && !(pfds = malloc(k * sizeof *pfds))) {
        errno = ENOMEM;
        return -1;
    }
    k = 0;
    for (int fd = 0; fd < nfds; fd++) {
        short ev = 0;
        if (r && FD_ISSET(fd, r))
            ev |= POLLIN;
        if (w && FD_ISSET(fd, w))
            ev |= POLLOUT;
        if (e && FD_ISSET(fd, e))
            ev |= POLLPRI;
        if (ev) {
            pfds[k].fd = fd;
            pfds[k].events = ev;
            pfds[k].revents = 0;
            k++;
        }
    }
    fd_set r0, w0, e0;
    if (r)
        r0 = *r;
    if (w)
        w0 = *w;
    if (e)
        e0 = *e;
    int result;
    for (;;) {
        int got = vt_wait(pfds, (nfds_t)k, deadline, mask, 0);
        if (got < 0) {
            result = -1;
            break;
        }
        int bad = 0;
        for (int i = 0; i < k; i++)
            bad |= pfds[i].revents & POLLNVAL;
        if (bad) {
            errno = EBADF;
            result = -1;
            break;
        }
        if (got == 0) {
            if (r)
                FD_ZERO(r);
            if (w)
                FD_ZERO(w);
            if (e)
                FD_ZERO(e);
            result = 0;
            break;
        }
        static const struct timespec zero = {0, 0};
        if (r)
            *r = r0;
        if (w)
            *w = w0;
        if (e)
            *e = e0;
        result = real_pselect(nfds, r, w, e, &zero, NULL);
        if (result != 0)
            break;
        /* the readiness went away before the sets were filled (another thread read): wait again */
    }
    if (left_ns && deadline != HVT_NO_DEADLINE) {
        int64_t left = deadline - vt_now();
        *left_ns = left > 0 ? left : 0;
    }
    if (pfds != stack)
        free(pfds);
    return result;
}

EXPORT int select(int nfds, fd_set *r, fd_set *w, fd_set *e, struct timeval *tv) {
    REAL(select, select_fn);
    if (!active())
        return real_select(nfds, r, w, e, tv);
    count(HVT_CALL_SELECT);
    if (tv && (tv->tv_sec < 0 || tv->tv_usec < 0)) {
        errno = EINVAL;
        return -1;
    }
    if (tv && tv->tv_sec == 0 && tv->tv_usec == 0) {
        clock_read();
        return real_select(nfds, r, w, e, tv);
    }
    int64_t deadline = tv ? vt_now() + tv->tv_sec * NS_PER_S + (int64_t)tv->tv_usec * 1000 : HVT_NO_DEADLINE;
    int64_t left = 0;
    int result = select_wait(nfds, r, w, e, deadline, NULL, &left);
    if (tv) { /* Linux reports the time not slept */
        tv->tv_sec = left / NS_PER_S;
        tv->tv_usec = (left % NS_PER_S) / 1000;
    }
    return result;
}

EXPORT int pselect(int nfds, fd_set *r, fd_set *w, fd_set *e, const struct timespec *ts, const sigset_t *mask) {
    REAL(pselect, pselect_fn);
    if (!active())
        return real_pselect(nfds, r, w, e, ts, mask);
    count(HVT_CALL_PSELECT);
    if (ts && !valid_ts(ts)) {
        errno = EINVAL;
        return -1;
    }
    if (ts && ts_ns(ts) == 0) {
        clock_read();
        return real_pselect(nfds, r, w, e, ts, mask);
    }
    return select_wait(nfds, r, w, e, ts ? vt_now() + ts_ns(ts) : HVT_NO_DEADLINE, mask, NULL);
}

/* epoll: wait for the epoll fd itself to become readable, then collect without blocking. */
static int epoll_common(int epfd, struct epoll_event *events, int max, int64_t deadline, const sigset_t *mask) {
    REAL(epoll_wait, epoll_wait_fn);
    for (;;) {
        struct pollfd p = {.fd = epfd, .events = POLLIN, .revents = 0};
        int got = vt_wait(&p, 1, deadline, mask, 1);
        if (got <= 0)
            return got;
        if (p.revents & POLLNVAL) {
            errno = EBADF;
            return -1;
        }
        int n = real_epoll_wait(epfd, events, max, 0);
        if (n != 0)
            return n;
    }
}

EXPORT int epoll_wait(int epfd, struct epoll_event *events, int max, int timeout_ms) {
    REAL(epoll_wait, epoll_wait_fn);
    if (!active() || timeout_ms == 0) {
        if (active()) {
            count(HVT_CALL_EPOLL_WAIT);
            clock_read();
        }
        return real_epoll_wait(epfd, events, max, timeout_ms);
    }
    count(HVT_CALL_EPOLL_WAIT);
    return epoll_common(epfd, events, max, deadline_after(timeout_ms < 0 ? -1 : (int64_t)timeout_ms * 1000000), NULL);
}

EXPORT int epoll_pwait(int epfd, struct epoll_event *events, int max, int timeout_ms, const sigset_t *mask) {
    REAL(epoll_pwait, epoll_pwait_fn);
    if (!active() || timeout_ms == 0) {
        if (active()) {
            count(HVT_CALL_EPOLL_PWAIT);
            clock_read();
        }
        return real_epoll_pwait(epfd, events, max, timeout_ms, mask);
    }
    count(HVT_CALL_EPOLL_PWAIT);
    return epoll_common(epfd, events, max, deadline_after(timeout_ms < 0 ? -1 : (int64_t)timeout_ms * 1000000), mask);
}

EXPORT int epoll_pwait2(int epfd, struct epoll_event *events, int max, const struct timespec *tmo,
                        const sigset_t *mask) {
    REAL(epoll_pwait2, epoll_pwait2_fn);
    if (!real_epoll_pwait2) {
        errno = ENOSYS;
        return -1;
    }
    if (!active() || (tmo && ts_ns(tmo) == 0)) {
        if (active()) {
            count(HVT_CALL_EPOLL_PWAIT2);
            clock_read();
        }
        return real_epoll_pwait2(epfd, events, max, tmo, mask);
    }
    count(HVT_CALL_EPOLL_PWAIT2);
    if (tmo && !valid_ts(tmo)) {
        errno = EINVAL;
        return -1;
    }
    return epoll_common(epfd, events, max, tmo ? vt_now() + ts_ns(tmo) : HVT_NO_DEADLINE, mask);
}

/* pthread_cond_* exist in two versions; the default symbol is the old one (libfaketime hit it). */
#if defined(__x86_64__)
#define COND_VERSION "GLIBC_2.3.2"
#else
#define COND_VERSION NULL
#endif

/* ---- waits on other threads: locks, semaphores, conditions, joins ------------------------
 *
 * Such a wait can only be ended by another thread of the flight code (or its timeout), so
 * while it lasts the thread is blocked as far as the bench is concerned. Published with
 * wait_kind FUTEX; the bench also asks the kernel (/proc) whether the thread is really
 * asleep, because a wake-up makes it runnable before it returns here. A timed wait carries
 * its deadline in sim time, but the wait itself ends on the host clock (a futex cannot wait
 * on the wake FIFO), so it is counted as uncovered.
 */

static struct hvt_slot *futex_enter(int64_t deadline) {
    struct hvt_slot *s = my_slot();
    if (!s || free_running())
        return NULL;
    publish_blocked(s, NULL, 0, deadline, load_u32(&H->epoch), 0, HVT_WAIT_FUTEX);
    notify_bench();
    return s;
}

static void futex_leave(struct hvt_slot *s) {
    if (s)
        publish_running(s);
}

/* The sim-time deadline of an absolute timeout read from clock id (none for host clocks). */
static int64_t sim_deadline(clockid_t id, const struct timespec *abs) {
    enum kind k = clock_kind(id);
    return (abs && virtual_kind(k)) ? ts_ns(abs) - clock_base(k) : HVT_NO_DEADLINE;
}

typedef int (*sem_wait_fn)(sem_t *);
typedef int (*cond_wait_fn)(pthread_cond_t *, pthread_mutex_t *);
typedef int (*mutex_lock_fn)(pthread_mutex_t *);
typedef int (*join_fn)(pthread_t, void **);
typedef int (*create_fn)(pthread_t *, const pthread_attr_t *, void *(*)(void *), void *);

EXPORT int sem_wait(sem_t *sem) {
    REAL(sem_wait, sem_wait_fn);
    if (!active())
        return real_sem_wait(sem);
    if (sem_trywait(sem) == 0)
        return 0;
    struct hvt_slot *s = futex_enter(HVT_NO_DEADLINE);
    int r = real_sem_wait(sem);
    int saved = errno;
    futex_leave(s);
    errno = saved;
    return r;
}

EXPORT int pthread_cond_wait(pthread_cond_t *cond, pthread_mutex_t *mutex) {
    REAL_V(pthread_cond_wait, cond_wait_fn, COND_VERSION);
    if (!active())
        return real_pthread_cond_wait(cond, mutex);
    struct hvt_slot *s = futex_enter(HVT_NO_DEADLINE);
    int r = real_pthread_cond_wait(cond, mutex);
    futex_leave(s);
    return r;
}

EXPORT int pthread_mutex_lock(pthread_mutex_t *mutex) {
    REAL(pthread_mutex_lock, mutex_lock_fn);
    if (!active())
        return real_pthread_mutex_lock(mutex);
    int r = pthread_mutex_trylock(mutex);
    if (r != EBUSY)
        return r; /* taken (or an error the blocking call would give too) */
    struct hvt_slot *s = futex_enter(HVT_NO_DEADLINE);
    r = real_pthread_mutex_lock(mutex);
    futex_leave(s);
    return r;
}

EXPORT int pthread_join(pthread_t thread, void **retval) {
    REAL(pthread_join, join_fn);
    if (!active())
        return real_pthread_join(thread, retval);
    struct hvt_slot *s = futex_enter(HVT_NO_DEADLINE);
    int r = real_pthread_join(thread, retval);
    futex_leave(s);
    return r;
}

/* ---- waits on other processes: children, tracees, pipe writers --------------------------
 *
 * A launcher (sh -c, make, strace, gdb, a script) waits for the flight code it started, or
 * reads what another process of the tree writes. Such a wait ends when another process of
 * the tree acts, so it is idle as far as the bench is concerned, like a futex wait: the slot
 * is published BLOCKED with its kind and the bench confirms in /proc that the kernel has the
 * thread asleep. A wait that can end at once is made without publishing (a WNOHANG probe, a
 * zero-timeout poll), so the slot is BLOCKED only where the real call will sleep.
 */


static struct hvt_slot *other_enter(const struct pollfd *fd, uint32_t kind, pid_t target) {
    struct hvt_slot *s = my_slot();
    if (!s || free_running())
        return NULL;
    count(kind == HVT_WAIT_CHILD ? HVT_CALL_WAIT_CHILD : HVT_CALL_READ_BLOCK);
    s->wait_pid = target; /* published with the state, below */
    publish_blocked(s, fd, fd ? 1 : 0, HVT_NO_DEADLINE, load_u32(&H->epoch), 0, kind);
    notify_bench();
    return s;
}

/* Running again; errno as the real call left it. */
static void other_leave(struct hvt_slot *s) {
    if (s) {
        int saved = errno;
        publish_running(s);
        errno = saved;
    }
}

static pid_t child_wait(pid_t pid, int *status, int options, struct rusage *ru) {
    REAL(wait4, wait4_fn);
    if (!active() || (options & WNOHANG))
        return real_wait4(pid, status, options, ru);
    pid_t r = real_wait4(pid, status, options | WNOHANG, ru);
    if (r != 0)
        return r; /* a child had changed state already, or none can (ECHILD) */
    struct hvt_slot *s = other_enter(NULL, HVT_WAIT_CHILD, pid);
    r = real_wait4(pid, status, options, ru);
    other_leave(s);
    return r;
}

EXPORT pid_t wait4(pid_t pid, int *status, int options, struct rusage *ru) {
    return child_wait(pid, status, options, ru);
}

EXPORT pid_t wait3(int *status, int options, struct rusage *ru) { return child_wait(-1, status, options, ru); }

EXPORT pid_t waitpid(pid_t pid, int *status, int options) { return child_wait(pid, status, options, NULL); }

EXPORT pid_t wait(int *status) { return child_wait(-1, status, 0, NULL); }

EXPORT int waitid(idtype_t idtype, id_t id, siginfo_t *info, int options) {
    REAL(waitid, waitid_fn);
    if (!active() || (options & WNOHANG))
        return real_waitid(idtype, id, info, options);
    info->si_pid = 0; /* WNOHANG with nothing to report leaves it 0 (waitid(2)) */
    int r = real_waitid(idtype, id, info, options | WNOHANG);
    if (r != 0 || info->si_pid != 0)
        return r;
    /* the same target in wait4's terms (P_PIDFD: any child, the bench errs on waiting) */
    pid_t target = idtype == P_PID ? (pid_t)id : idtype == P_PGID ? (id ? -(pid_t)id : 0) : -1;
    struct hvt_slot *s = other_enter(NULL, HVT_WAIT_CHILD, target);
    r = real_waitid(idtype, id, info, options);
    other_leave(s);
    return r;
}

/* A read of fd would sleep: nothing to read now, a blocking descriptor, and no termios
 * timeout (a tty read with VTIME ends on the host clock: left to run as a plain call).
 * Only for threads that already have a slot; the ready path costs one zero-timeout poll. */
static struct hvt_slot *read_enter(int fd) {
    REAL(ppoll, ppoll_fn);
    static const struct timespec zero = {0, 0};
    if (tl_claim != 1 || !active() || free_running())
        return NULL;
    struct pollfd p = {.fd = fd, .events = POLLIN, .revents = 0};
    if (real_ppoll(&p, 1, &zero, NULL) != 0)
        return NULL; /* readable, at its end, or an error the read itself reports */
    int flags = fcntl(fd, F_GETFL);
    if (flags < 0 || (flags & O_NONBLOCK))
        return NULL;
    struct termios tio;
    if (tcgetattr(fd, &tio) == 0 && !(tio.c_lflag & ICANON) && tio.c_cc[VTIME] != 0)
        return NULL;
    return other_enter(&p, HVT_WAIT_READ, 0);
}

EXPORT ssize_t read(int fd, void *buf, size_t n) {
    REAL(read, read_fn);
    struct hvt_slot *s = read_enter(fd);
    ssize_t r = real_read(fd, buf, n);
    other_leave(s);
    return r;
}

EXPORT ssize_t readv(int fd, const struct iovec *iov, int n) {
    REAL(readv, readv_fn);
    struct hvt_slot *s = read_enter(fd);
    ssize_t r = real_readv(fd, iov, n);
    other_leave(s);
    return r;
}

/* What read() becomes in a program built with _FORTIFY_SOURCE when the buffer's size is known. */
EXPORT ssize_t __read_chk(int fd, void *buf, size_t n, size_t buflen) {
    REAL(__read_chk, read_chk_fn);
    struct hvt_slot *s = read_enter(fd);
    ssize_t r = real___read_chk(fd, buf, n, buflen);
    other_leave(s);
    return r;
}

struct start {
    void *(*fn)(void *);
    void *arg;
    int index;
};

static void *start_thread(void *p) {
    struct start st = *(struct start *)p;
    free(p);
    claim(st.index);
    return st.fn(st.arg);
}

/* The creator reserves the new thread's slot (running) before the thread exists, so the
 * bench never sees an instant where it runs unregistered. */
EXPORT int pthread_create(pthread_t *thread, const pthread_attr_t *attr, void *(*fn)(void *), void *arg) {
    REAL(pthread_create, create_fn);
    if (!H || free_running())
        return real_pthread_create(thread, attr, fn, arg);
    int index = -1;
    for (int i = 0; i < HVT_MAX_THREADS && index < 0; i++) {
        int32_t expected = 0;
        if (__atomic_compare_exchange_n(&SLOTS[i].tid, &expected, -1, 0, __ATOMIC_ACQ_REL, __ATOMIC_RELAXED))
            index = i;
    }
    struct start *st = index >= 0 ? malloc(sizeof *st) : NULL;
    if (!st) {
        if (index >= 0)
            __atomic_store_n(&SLOTS[index].tid, 0, __ATOMIC_RELEASE);
        return real_pthread_create(thread, attr, fn, arg); /* it claims a slot itself, or none */
    }
    struct hvt_slot *slot = &SLOTS[index];
    slot->pid = getpid();
    uint32_t seq = __atomic_load_n(&slot->seq, __ATOMIC_RELAXED);
    __atomic_store_n(&slot->state, HVT_RUNNING, __ATOMIC_RELEASE);
    __atomic_store_n(&slot->seq, seq + (seq & 1u), __ATOMIC_RELEASE);
    st->fn = fn;
    st->arg = arg;
    st->index = index;
    int r = real_pthread_create(thread, attr, start_thread, st);
    if (r != 0) {
        free(st);
        __atomic_store_n(&slot->state, HVT_FREE, __ATOMIC_RELEASE);
        __atomic_store_n(&slot->tid, 0, __ATOMIC_RELEASE);
    }
    return r;
}

/* ---- uncovered: counted, so the bench can warn ----------------------------------------- */

EXPORT int timerfd_create(int clockid, int flags) {
    REAL(timerfd_create, timerfd_create_fn);
    count(HVT_CALL_TIMERFD);
    return real_timerfd_create(clockid, flags);
}

EXPORT int timer_create(clockid_t clockid, struct sigevent *sev, timer_t *timer) {
    REAL(timer_create, timer_create_fn);
    count(HVT_CALL_TIMER_CREATE);
    return real_timer_create(clockid, sev, timer);
}

EXPORT int setitimer(__itimer_which_t which, const struct itimerval *value, struct itimerval *old) {
    REAL(setitimer, setitimer_fn);
    count(HVT_CALL_SETITIMER);
    return real_setitimer(which, value, old);
}

EXPORT unsigned alarm(unsigned seconds) {
    REAL(alarm, alarm_fn);
    count(HVT_CALL_ALARM);
    return real_alarm(seconds);
}

/* An absolute deadline read from a virtual clock, moved onto the host clock of the same id. */
static struct timespec to_host(clockid_t id, const struct timespec *abs) {
    REAL(clock_gettime, clock_gettime_fn);
    enum kind k = clock_kind(id);
    if (!active() || !abs || !virtual_kind(k))
        return abs ? *abs : ns_ts(0);
    struct timespec host;
    real_clock_gettime(id, &host);
    return ns_ts(ts_ns(&host) + (ts_ns(abs) - (clock_base(k) + vt_now())));
}

/* glibc keeps a condition variable's clock in bit 1 of __wrefs (nptl/pthread_cond_common.c). */
static clockid_t cond_clock(const pthread_cond_t *cond) {
    unsigned wrefs = __atomic_load_n(&cond->__data.__wrefs, __ATOMIC_RELAXED);
    return (wrefs & 2u) ? CLOCK_MONOTONIC : CLOCK_REALTIME;
}

EXPORT int pthread_cond_timedwait(pthread_cond_t *cond, pthread_mutex_t *mutex, const struct timespec *abs) {
    REAL_V(pthread_cond_timedwait, cond_timedwait_fn, COND_VERSION);
    if (!active())
        return real_pthread_cond_timedwait(cond, mutex, abs);
    count(HVT_CALL_COND_TIMEDWAIT);
    struct timespec host = to_host(cond_clock(cond), abs);
    struct hvt_slot *s = futex_enter(sim_deadline(cond_clock(cond), abs));
    int r = real_pthread_cond_timedwait(cond, mutex, &host);
    int saved = errno;
    futex_leave(s);
    errno = saved;
    return r;
}

EXPORT int pthread_cond_clockwait(pthread_cond_t *cond, pthread_mutex_t *mutex, clockid_t id,
                                  const struct timespec *abs) {
    REAL(pthread_cond_clockwait, cond_clockwait_fn);
    if (!active())
        return real_pthread_cond_clockwait(cond, mutex, id, abs);
    count(HVT_CALL_COND_TIMEDWAIT);
    struct timespec host = to_host(id, abs);
    struct hvt_slot *s = futex_enter(sim_deadline(id, abs));
    int r = real_pthread_cond_clockwait(cond, mutex, id, &host);
    int saved = errno;
    futex_leave(s);
    errno = saved;
    return r;
}

EXPORT int sem_timedwait(sem_t *sem, const struct timespec *abs) {
    REAL(sem_timedwait, sem_timedwait_fn);
    if (!active())
        return real_sem_timedwait(sem, abs);
    count(HVT_CALL_SEM_TIMEDWAIT);
    struct timespec host = to_host(CLOCK_REALTIME, abs);
    struct hvt_slot *s = futex_enter(sim_deadline(CLOCK_REALTIME, abs));
    int r = real_sem_timedwait(sem, &host);
    int saved = errno;
    futex_leave(s);
    errno = saved;
    return r;
}

EXPORT int sem_clockwait(sem_t *sem, clockid_t id, const struct timespec *abs) {
    REAL(sem_clockwait, sem_clockwait_fn);
    if (!active())
        return real_sem_clockwait(sem, id, abs);
    count(HVT_CALL_SEM_TIMEDWAIT);
    struct timespec host = to_host(id, abs);
    struct hvt_slot *s = futex_enter(sim_deadline(id, abs));
    int r = real_sem_clockwait(sem, id, &host);
    int saved = errno;
    futex_leave(s);
    errno = saved;
    return r;
}

EXPORT int pthread_mutex_timedlock(pthread_mutex_t *mutex, const struct timespec *abs) {
    REAL(pthread_mutex_timedlock, mutex_timedlock_fn);
    if (!active())
        return real_pthread_mutex_timedlock(mutex, abs);
    count(HVT_CALL_MUTEX_TIMEDLOCK);
    struct timespec host = to_host(CLOCK_REALTIME, abs);
    struct hvt_slot *s = futex_enter(sim_deadline(CLOCK_REALTIME, abs));
    int r = real_pthread_mutex_timedlock(mutex, &host);
    int saved = errno;
    futex_leave(s);
    errno = saved;
    return r;
}

/* ---- attach / detach ------------------------------------------------------------------- */

static void after_fork_in_child(void) {
    /* The child is a new process: its threads claim slots of their own. */
    if (tl_wake_fd >= 0)
        close(tl_wake_fd);
    tl_wake_fd = -1;
    tl_slot = NULL;
    tl_claim = 0;
    if (H)
        __atomic_fetch_add(&H->attached, 1, __ATOMIC_ACQ_REL);
}

__attribute__((constructor)) static void hvt_attach(void) {
    const char *path = getenv("HIL_VT_CTL");
    if (!path || !*path || strlen(path) >= sizeof ctl_path)
        return;
    int fd = open(path, O_RDWR | O_CLOEXEC);
    if (fd < 0)
        return;
    struct stat st;
    size_t size = sizeof(struct hvt_header) + HVT_MAX_THREADS * sizeof(struct hvt_slot);
    if (fstat(fd, &st) != 0 || (size_t)st.st_size < size) {
        close(fd);
        return;
    }
    void *map = mmap(NULL, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    close(fd);
    if (map == MAP_FAILED)
        return;
    struct hvt_header *h = map;
    if (h->magic != HVT_MAGIC || h->version != HVT_VERSION || h->slot_size != sizeof(struct hvt_slot)) {
        munmap(map, size);
        return;
    }
    strcpy(ctl_path, path);
    char fifo[4200];
    snprintf(fifo, sizeof fifo, "%s.n", path);
    notify_fd = open(fifo, O_WRONLY | O_NONBLOCK | O_CLOEXEC);
    pthread_key_create(&slot_key, release_slot);
    pthread_atfork(NULL, NULL, after_fork_in_child);
    SLOTS = (struct hvt_slot *)((char *)map + sizeof(struct hvt_header));
    H = h;
    __atomic_fetch_add(&H->attached, 1, __ATOMIC_ACQ_REL);
    my_slot(); /* the main thread is running from now on: the bench waits for it */
    if (notify_fd >= 0) {
        ssize_t w = write(notify_fd, "a", 1); /* attached: the bench may stop waiting for us */
        (void)w;
    }
}

__attribute__((destructor)) static void hvt_detach(void) {
    /* exit(): the main thread is done (a kill leaves its slot to the bench to clear) */
    release_slot(NULL);
}
