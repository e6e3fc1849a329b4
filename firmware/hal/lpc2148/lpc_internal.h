/*
 * lpc_internal.h - what the lpc2148 hardware layer's files share: interrupt masking, idle,
 * the microsecond time base (Timer1), the wake-up alarm, semihosting, the counters.
 */
#ifndef FW_LPC_INTERNAL_H
#define FW_LPC_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "hal.h"

#define ESC_RATE_HZ 400u     /* the ESC pulse rate: one pulse per 2.5 ms loop period */
#define ESC_PERIOD_US (1000000u / ESC_RATE_HZ)

extern hal_counters_t lpc_counters;

/* The CPSR's I bit: the previous state, to restore. */
static inline uint32_t irq_save(void)
{
    uint32_t cpsr, masked;
    __asm__ volatile("mrs %0, cpsr\n\torr %1, %0, #0x80\n\tmsr cpsr_c, %1" : "=r"(cpsr), "=r"(masked) : : "memory");
    return cpsr;
}

static inline void irq_restore(uint32_t cpsr)
{
    __asm__ volatile("msr cpsr_c, %0" : : "r"(cpsr) : "memory");
}

static inline void irq_enable(void)
{
    uint32_t cpsr;
    __asm__ volatile("mrs %0, cpsr\n\tbic %0, %0, #0xC0\n\tmsr cpsr_c, %0" : "=r"(cpsr) : : "memory");
}

/* Idle until an interrupt (PCON.IDL). Called with IRQs masked: a request still wakes the core,
 * and the caller takes it when it unmasks (no lost wake-up between its check and the sleep). */
void lpc_idle(void);

/* Microseconds since hal_open on Timer1, extended to 64 bits. */
uint64_t lpc_now_us(void);

/* Arm the wake-up alarm (Timer1 MR1) for the Timer1 count at_us (its low 32 bits). */
void lpc_alarm(uint64_t at_us);

/* Wait (idle) until ready() or until deadline_us; true if ready. */
bool lpc_wait(bool (*ready)(void *), void *arg, uint64_t deadline_us);

/* Semihosting (ARM DUI 0471): the bench serves it; a board without a debugger returns at once. */
int lpc_semihost(int op, const void *arg);

/* The Timer1 interrupt's parts: PPM captures (hal_rc_esc.c). */
void lpc_capture_isr(void);
void lpc_esc_timer_isr(uint32_t ir);

/* Set up at hal_open. */
int lpc_uart_open(hal_uart_t uart, uint32_t baud);
void lpc_rc_open(bool capture);
void lpc_esc_open(void);
void lpc_spi_config(uint32_t speed_hz);
void lpc_uart_isr0(void) __attribute__((interrupt("IRQ")));
void lpc_uart_isr1(void) __attribute__((interrupt("IRQ")));

#endif /* FW_LPC_INTERNAL_H */
