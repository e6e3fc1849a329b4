/*
 * The emulated LPC2148's cycle counter: Unicorn block and probe hooks in C (docs/board.md,
 * "The cycle model").
 *
 * A Python call per instruction, or even per block, would cost more than the emulation itself,
 * so the counting runs here. hil/board/blocks.py decodes a basic block once, the first time
 * Unicorn runs it, and stores its static cost (ARM7TDMI TRM timings, every instruction
 * executed, multipliers at m = 1) with the few data-dependent items it holds: a condition that
 * may fail, a multiplier whose operand sets m. Each item is evaluated where its inputs are
 * known: at the block's start (no earlier instruction of the block writes them), at its end
 * (no later one does) or, failing both, by a probe (a Unicorn code hook on that one
 * instruction). The final transfer of a block counts as taken when the next block does not
 * start at the fall-through address.
 *
 * The MAM's flash timing is applied per block from line-level facts the decoder stores (the
 * 128-bit lines the block's fetches open, the cycles spent in each, its PC-relative flash data
 * reads) and the MAM state kept here (current line, branch trail line, data buffer line).
 *
 * This is a plain shared library loaded with ctypes (hil/board/native.py); it calls Unicorn
 * through function pointers the Python side fills in, so it links against nothing.
 */
#include <stdint.h>
#include <stddef.h>

#define EXPORT __attribute__((visibility("default")))

typedef int (*reg_read_fn)(void *uc, int regid, void *value);
typedef int (*reg_write_fn)(void *uc, int regid, const void *value);
typedef int (*emu_stop_fn)(void *uc);
/* decode the block at address (size bytes) and insert it; returns a MISS_* code */
typedef int (*miss_fn)(uint32_t address, uint32_t size);

enum { MISS_INSERTED = 0, MISS_RETRANSLATE = 1, MISS_FAILED = 2 };

enum {
    STOP_NONE = 0,
    STOP_DEADLINE = 1,    /* the next block starts at or after the deadline */
    STOP_REQUEST = 2,     /* the Python side asked (an MMIO access that needs the run loop) */
    STOP_RETRANSLATE = 3, /* a block needs probes: drop its translation and run it again */
    STOP_UNMASKED = 4,    /* an interrupt is pending and the CPSR no longer masks it */
    STOP_SELF_LOOP = 5,   /* a branch to itself: the run loop skips time */
    STOP_MISS_FAILED = 6
};

/* block flags */
enum {
    B_XFER = 1,      /* ends with an unconditional transfer (always taken) */
    B_COND_XFER = 2, /* ends with a conditional transfer: taken when the next block is elsewhere */
    B_SELF_LOOP = 4, /* one unconditional branch to itself */
    B_FLASH = 8      /* fetched from on-chip flash (through the MAM) */
};

/* where a data-dependent item is evaluated */
enum { AT_START = 0, AT_END = 1, AT_PROBE = 2 };

#define COND_ALWAYS 14
#define NO_REG 0xFF
#define NO_LINE 0xFFFFFFFFu
#define CPSR_T 0x20u

typedef struct {
    uint8_t cond;         /* ARM condition 0-13, COND_ALWAYS */
    uint8_t mul_reg;      /* register number 0-15 of the multiplier operand, NO_REG */
    uint8_t mul_unsigned; /* UMULL/UMLAL: only all-zero top bits end early */
    uint8_t when;
    int32_t false_delta;  /* cycles added when the condition fails (1S - the executed cost) */
} item_t;

typedef struct {
    uint32_t addr;         /* key */
    uint32_t size;         /* key, bytes; 0: empty slot */
    uint32_t cost;         /* static cycles */
    uint32_t taken_extra;  /* added when a final conditional transfer is taken */
    uint32_t fall;         /* the address after the block */
    uint32_t n_instr;
    uint32_t flags;
    uint32_t item_first;   /* start items, then end items, in the item pool */
    uint16_t n_start, n_end;
    uint32_t first_line, last_line;
    uint32_t cross_first;  /* cycles spent in each line before leaving it (n_cross of them) */
    uint32_t n_cross;
    uint32_t lit_first;    /* lines of PC-relative flash data reads */
    uint32_t n_lit;
    uint32_t tail_cycles;  /* cycles spent in the last line */
    uint32_t total_cycles; /* static cycles of the block's instructions (for the line timing) */
} block_t;

typedef struct state state_t;

typedef struct {
    state_t *state;
    item_t item;
} probe_t;

struct state {
    uint64_t cycles;      /* CCLK cycles: the current block's start plus its cost */
    uint64_t block_start; /* the current block's first cycle (peripheral accesses are timed here) */
    uint64_t deadline;
    uint64_t blocks, instructions;
    uint64_t evals_start, evals_end, evals_probe;
    uint32_t stop_reason;
    uint32_t stop_request;
    uint32_t irq_watch;    /* CPSR bits (I 0x80, F 0x40): stop once any of them is clear */
    uint32_t next_nonseq;  /* the next block is entered by a transfer (taken branch, exception) */
    uint32_t last_cost;    /* cycles charged for the last block entered */
    uint32_t miss_addr, miss_size;
    uint32_t cur_addr, cur_size; /* the block entered last (peripheral accesses are its) */
    block_t *prev;         /* the block that ran last and is not settled yet */
    block_t *last;         /* the block entered last */
    /* the MAM (UM10139 chapter 4): mode 0-2, flash access time in cycles (MAMTIM) */
    uint32_t mam_mode, mam_cycles;
    uint32_t cur_line, btb_line, data_line;
    uint32_t carried;      /* cycles spent so far in cur_line */
    /* tables, owned by the Python side */
    block_t *table;
    uint32_t mask;
    item_t *items;
    uint32_t *cross;
    uint32_t *lits;
    /* Unicorn */
    void *uc;
    reg_read_fn reg_read;
    reg_write_fn reg_write;
    emu_stop_fn emu_stop;
    miss_fn miss;
    int32_t regid[16];
    int32_t cpsr_id, spsr_id;
};

static uint32_t read_reg(state_t *s, int regid) {
    uint32_t v = 0;
    s->reg_read(s->uc, regid, &v);
    return v;
}

/* ARM condition codes on the NZCV flags (ARM ARM A3.2) */
static int cond_passed(uint32_t cpsr, uint32_t cond) {
    uint32_t n = cpsr >> 31 & 1, z = cpsr >> 30 & 1, c = cpsr >> 29 & 1, v = cpsr >> 28 & 1;
    switch (cond) {
    case 0: return z;
    case 1: return !z;
    case 2: return c;
    case 3: return !c;
    case 4: return n;
    case 5: return !n;
    case 6: return v;
    case 7: return !v;
    case 8: return c && !z;
    case 9: return !c || z;
    case 10: return n == v;
    case 11: return n != v;
    case 12: return !z && n == v;
    case 13: return z || n != v;
    default: return 1;
    }
}

/* multiplier early termination (ARM7TDMI TRM, instruction speed summary): the 8-bit multiplier
 * array cycles m for the operand's significant bytes */
static uint32_t mul_m(uint32_t rs, int is_unsigned) {
    uint32_t masks[3] = {0xFFFFFF00u, 0xFFFF0000u, 0xFF000000u};
    for (uint32_t i = 0; i < 3; i++) {
        uint32_t top = rs & masks[i];
        if (top == 0 || (!is_unsigned && top == masks[i]))
            return i + 1;
    }
    return 4;
}

static int64_t item_delta(state_t *s, const item_t *it, int *have_cpsr, uint32_t *cpsr) {
    if (it->cond != COND_ALWAYS) {
        if (!*have_cpsr) {
            *cpsr = read_reg(s, s->cpsr_id);
            *have_cpsr = 1;
        }
        if (!cond_passed(*cpsr, it->cond))
            return it->false_delta;
    }
    if (it->mul_reg != NO_REG)
        return (int64_t)mul_m(read_reg(s, s->regid[it->mul_reg]), it->mul_unsigned) - 1;
    return 0;
}

static void eval_items(state_t *s, uint32_t first, uint32_t n, uint64_t *counter) {
    int have_cpsr = 0;
    uint32_t cpsr = 0;
    for (uint32_t i = 0; i < n; i++)
        s->cycles += (uint64_t)item_delta(s, &s->items[first + i], &have_cpsr, &cpsr);
    *counter += n;
}

/* settle the block that ran last, now that the next one is known to start at next: its end
 * items (registers and flags are its end state) and whether its final transfer was taken */
static void settle(state_t *s, uint32_t next) {
    block_t *p = s->prev;
    if (!p)
        return;
    s->prev = NULL;
    if (p->n_end)
        eval_items(s, p->item_first + p->n_start, p->n_end, &s->evals_end);
    if (p->flags & B_XFER) {
        s->next_nonseq = 1;
    } else if ((p->flags & B_COND_XFER) && next != p->fall) {
        s->cycles += p->taken_extra;
        s->next_nonseq = 1;
    }
}

/* flash wait cycles of entering and running block b (docs/board.md, "The MAM") */
static uint32_t mam_cycles(state_t *s, const block_t *b, int nonseq) {
    if (!(b->flags & B_FLASH)) {
        s->cur_line = NO_LINE;
        return 0;
    }
    uint32_t t = s->mam_cycles, wait = t - 1, extra = 0;
    if (s->mam_mode == 0) {
        /* every fetch and every flash data read takes a full flash access; a transfer
         * refills the pipeline with two more fetches */
        extra = wait * (b->n_instr + b->n_lit + (nonseq ? 2 : 0));
        s->cur_line = b->last_line;
        return extra;
    }
    uint32_t elapsed;
    if (nonseq) {
        uint32_t line = b->first_line;
        if (s->mam_mode == 2 && (line == s->cur_line || line == s->btb_line)) {
            /* in the current line's latch or the branch trail buffer */
        } else {
            extra += wait;
            s->btb_line = line;
        }
        elapsed = 0;
    } else if (b->first_line == s->cur_line) {
        elapsed = s->carried;
    } else {
        /* sequential into a new line: its prefetch began when the previous line arrived */
        uint32_t since = s->carried;
        if (since < t)
            extra += t - since;
        elapsed = 0;
    }
    for (uint32_t i = 0; i < b->n_cross; i++) {
        uint32_t since = elapsed + s->cross[b->cross_first + i];
        if (since < t)
            extra += t - since;
        elapsed = 0;
    }
    if (b->n_cross == 0 && b->first_line == b->last_line)
        s->carried = elapsed + b->total_cycles;
    else
        s->carried = b->tail_cycles;
    s->cur_line = b->last_line;
    for (uint32_t i = 0; i < b->n_lit; i++) {
        uint32_t line = s->lits[b->lit_first + i];
        if (s->mam_mode == 2 && line == s->data_line)
            continue;
        extra += wait;
        s->data_line = line;
    }
    return extra;
}

static block_t *lookup(state_t *s, uint32_t addr, uint32_t size) {
    uint32_t h = ((addr >> 1) * 2654435761u) & s->mask;
    for (;;) {
        block_t *e = &s->table[h];
        if (e->size == 0)
            return NULL;
        if (e->addr == addr && e->size == size)
            return e;
        h = (h + 1) & s->mask;
    }
}

static void stop(state_t *s, uint32_t reason) {
    s->stop_reason = reason;
    s->emu_stop(s->uc);
}

EXPORT void cyc_block_hook(void *uc, uint64_t address, uint32_t size, void *user) {
    state_t *s = user;
    uint32_t a = (uint32_t)address;
    (void)uc;
    settle(s, a);
    if (s->stop_request) {
        s->stop_request = 0;
        stop(s, STOP_REQUEST);
        return;
    }
    if (s->cycles >= s->deadline) {
        stop(s, STOP_DEADLINE);
        return;
    }
    if (s->irq_watch && (read_reg(s, s->cpsr_id) & s->irq_watch) != s->irq_watch) {
        stop(s, STOP_UNMASKED);
        return;
    }
    block_t *b = lookup(s, a, size);
    if (!b) {
        s->miss_addr = a;
        s->miss_size = size;
        int r = s->miss(a, size);
        if (r == MISS_RETRANSLATE) {
            stop(s, STOP_RETRANSLATE);
            return;
        }
        b = lookup(s, a, size);
        if (r != MISS_INSERTED || !b) {
            stop(s, STOP_MISS_FAILED);
            return;
        }
    }
    int nonseq = (int)s->next_nonseq;
    if ((b->flags & B_SELF_LOOP) && nonseq && b == s->last) {
        /* the second pass through `b .`: the run loop skips the iterations */
        stop(s, STOP_SELF_LOOP);
        return;
    }
    s->next_nonseq = 0;
    s->block_start = s->cycles;
    s->cur_addr = a;
    s->cur_size = size;
    uint64_t c = (uint64_t)b->cost + mam_cycles(s, b, nonseq);
    s->cycles += c;
    if (b->n_start)
        eval_items(s, b->item_first, b->n_start, &s->evals_start);
    s->last_cost = (uint32_t)(s->cycles - s->block_start);
    s->instructions += b->n_instr;
    s->blocks++;
    s->prev = b;
    s->last = b;
}

EXPORT void cyc_probe_hook(void *uc, uint64_t address, uint32_t size, void *user) {
    probe_t *p = user;
    state_t *s = p->state;
    int have_cpsr = 0;
    uint32_t cpsr = 0;
    (void)uc, (void)address, (void)size;
    s->cycles += (uint64_t)item_delta(s, &p->item, &have_cpsr, &cpsr);
    s->evals_probe++;
}

/* After a run slice: settle the last block against the PC the core will go on from. */
EXPORT void cyc_settle(state_t *s, uint32_t next_pc) {
    settle(s, next_pc);
}

/* ARM exception entry (ARM ARM A2.6): the banked registers, SPSR, LR = the next instruction's
 * address + 4, I (and F for FIQ, reset, ...) set, ARM state, the vector; 2S+1N cycles. mode is
 * the new CPSR mode (0x11 FIQ, 0x12 IRQ, 0x13 SVC...), mask the CPSR bits to set (0x80 I, 0x40 F). */
EXPORT void cyc_enter_exception(state_t *s, uint32_t mode, uint32_t mask, uint32_t vector, uint32_t lr_offset) {
    uint32_t pc = read_reg(s, s->regid[15]);
    settle(s, pc);
    uint32_t cpsr = read_reg(s, s->cpsr_id);
    uint32_t ncpsr = (cpsr & ~(0x1Fu | CPSR_T)) | mode | mask;
    uint32_t lr = pc + lr_offset;
    s->reg_write(s->uc, s->cpsr_id, &ncpsr); /* switches the register bank */
    s->reg_write(s->uc, s->spsr_id, &cpsr);
    s->reg_write(s->uc, s->regid[14], &lr);
    s->reg_write(s->uc, s->regid[15], &vector);
    s->cycles += 3;
    s->next_nonseq = 1;
}
