/*
 * The control block shared by the bench and the clock shim (hil/vtime/shim.c).
 *
 * One file (mode 0600, in the run's 0700 directory) mapped MAP_SHARED by both sides.
 * The Python mirror is hil/vtime/abi.py; tests/unit/vtime/test_abi.py checks that the
 * two agree field by field (the shim exports hvt_abi_layout below).
 *
 * Writers: the bench writes the header's clock fields, mode and epoch; each flight-code
 * thread writes only its own slot. Every flag the other side acts on is published last,
 * with release ordering (the bench runs on x86-64/aarch64 with aligned 32-bit stores).
 */
#ifndef HVT_ABI_H
#define HVT_ABI_H

#include <stdint.h>

#define HVT_MAGIC 0x31545648u /* "HVT1" */
#define HVT_VERSION 1u
#define HVT_MAX_THREADS 16
#define HVT_MAX_KEYS 8
#define HVT_NO_DEADLINE INT64_MAX
#define HVT_KEYS_UNKNOWN 0xFFFFFFFFu /* epoll: the wait set is not known to the shim */

/* header.mode */
enum hvt_mode {
    HVT_MODE_OFF = 0,      /* not started: the shim passes everything through */
    HVT_MODE_VIRTUAL = 1,  /* the bench is the scheduler: clocks read sim time */
    HVT_MODE_FREE_RUN = 2, /* teardown: clocks continue from sim time at the host's rate */
};

/* slot.wait_kind: how a BLOCKED thread waits */
enum hvt_wait {
    HVT_WAIT_FD = 0,    /* on fds and/or its wake FIFO: the bench can end it */
    HVT_WAIT_FUTEX = 1, /* on a lock, semaphore, condition or join: another thread ends it
                         * (the bench checks /proc that the kernel has it asleep) */
    HVT_WAIT_CHILD = 2, /* wait, waitpid, wait3, wait4, waitid: a child or tracee of the flight
                         * command's process tree ends it (kernel-confirmed, like FUTEX) */
    HVT_WAIT_READ = 3,  /* read/readv on a descriptor with nothing to read: its writer ends it
                         * (kernel-confirmed; key_rdev names it if it is a character device) */
};

/* slot.state */
enum hvt_state {
    HVT_FREE = 0,
    HVT_RUNNING = 1,
    HVT_BLOCKED = 2,
};

/* header.calls[] indices: which interposed calls the flight code used. The uncovered
 * ones (HVT_CALL_FIRST_UNCOVERED and after) run on the host clock and make the bench warn. */
enum hvt_call {
    HVT_CALL_CLOCK_GETTIME = 0,
    HVT_CALL_GETTIMEOFDAY,
    HVT_CALL_TIME,
    HVT_CALL_TIMESPEC_GET,
    HVT_CALL_NANOSLEEP,
    HVT_CALL_CLOCK_NANOSLEEP,
    HVT_CALL_USLEEP,
    HVT_CALL_SLEEP,
    HVT_CALL_SELECT,
    HVT_CALL_PSELECT,
    HVT_CALL_POLL,
    HVT_CALL_PPOLL,
    HVT_CALL_EPOLL_WAIT,
    HVT_CALL_EPOLL_PWAIT,
    HVT_CALL_EPOLL_PWAIT2,
    HVT_CALL_CPU_CLOCK,        /* CPU-time clocks: passed through by design */
    HVT_CALL_SPIN_YIELD,       /* busy-wait on the clock detected: a quantum of sim time granted */
    HVT_CALL_WAIT_CHILD,       /* a wait for a child that blocked (published as HVT_WAIT_CHILD) */
    HVT_CALL_READ_BLOCK,       /* a read that would block (published as HVT_WAIT_READ) */
    HVT_CALL_FIRST_UNCOVERED = 20,
    HVT_CALL_CLOCK_OTHER = 20, /* clock_gettime/clock_nanosleep on a clock the shim does not model */
    HVT_CALL_TIMERFD,
    HVT_CALL_TIMER_CREATE,
    HVT_CALL_SETITIMER,
    HVT_CALL_ALARM,
    HVT_CALL_COND_TIMEDWAIT,   /* futex waits: deadline translated, waits on the host clock */
    HVT_CALL_SEM_TIMEDWAIT,
    HVT_CALL_MUTEX_TIMEDLOCK,
    HVT_CALL_NO_SLOT,          /* a thread beyond HVT_MAX_THREADS: its waits run on the host clock */
    HVT_N_CALLS = 32,
};

struct hvt_header {
    uint32_t magic;
    uint32_t version;
    uint32_t max_threads;
    uint32_t slot_size;
    /* The flight code's clock: ns since its start, written by the bench under time_seq
     * (odd while a write is in progress). */
    uint32_t time_seq;
    uint32_t mode;
    int64_t now_ns;
    int64_t mono_base_ns;      /* CLOCK_MONOTONIC/_RAW/_COARSE/BOOTTIME = base + now */
    int64_t real_base_ns;      /* CLOCK_REALTIME/_COARSE = Unix ns at now = 0 */
    int64_t tai_offset_ns;     /* CLOCK_TAI = REALTIME + this */
    int64_t free_run_host_ns;  /* host CLOCK_MONOTONIC when mode became FREE_RUN */
    int64_t spin_quantum_ns;   /* sim time granted to a thread caught busy-waiting */
    uint32_t spin_limit;       /* clock reads without a blocking call that count as a busy-wait */
    uint32_t epoch;            /* bumped by the bench after it wrote to the flight code */
    int32_t bench_pid;
    uint32_t attached;         /* processes that mapped the block (incremented by the shim) */
    uint64_t calls[HVT_N_CALLS];
};

struct hvt_slot {
    int32_t tid;               /* 0: free */
    int32_t pid;
    uint32_t state;            /* enum hvt_state */
    uint32_t seq;              /* +1 on every state change (odd: BLOCKED) */
    int64_t deadline_ns;       /* flight-code clock; HVT_NO_DEADLINE for none */
    int64_t cpu_ns;            /* the thread's CPU time when it last blocked */
    uint64_t blocks;           /* blocking calls so far */
    uint32_t seen_epoch;       /* header.epoch read before the thread's last readiness check */
    uint32_t nkeys;            /* wait-set entries that are character devices, or HVT_KEYS_UNKNOWN */
    uint32_t key_rdev[HVT_MAX_KEYS];   /* (major << 20) | minor, as the kernel encodes dev_t */
    uint16_t key_events[HVT_MAX_KEYS]; /* poll events the thread waits for on that device */
    uint32_t spin_yields;
    uint32_t clock_reads;      /* since the last blocking call (busy-wait detection) */
    uint32_t wait_kind;        /* enum hvt_wait, valid while BLOCKED */
    int32_t wait_pid;          /* a CHILD wait's target, as wait4 takes it: -1 any child, >0 that
                                * pid, 0 its own process group, < -1 the group -wait_pid */
    uint64_t reserved[2];
};

#endif
