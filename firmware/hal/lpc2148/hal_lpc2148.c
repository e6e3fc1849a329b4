/*
 * hal_lpc2148.c - the hardware layer on the NXP LPC2148: bring-up, the VIC, time, idle, the log
 * console (semihosting), faults. The UARTs, SPI0, the PPM capture and the ESC outputs have
 * their own files; lpc2148.h has the pin map.
 *
 * Interrupts (vectored, VIC slots by priority): 0 UART0 (the IMU: 69-byte bursts at 921600
 * baud, the FIFO must not overrun), 1 Timer1 (PPM captures, the ESC match outputs, the wake-up
 * alarm), 2 UART1 (the XBee). No nesting: each handler runs with IRQs masked.
 */
#include <stdio.h>
#include <string.h>

#include "hal.h"
#include "lpc2148.h"
#include "lpc_internal.h"

hal_counters_t lpc_counters;

static struct {
    const char *error;
    char error_text[96];
    uint32_t last_tc;
    uint32_t high;
    bool open;
} g;

static const char *const dev_names[HAL_DEV_COUNT] = {"imu", "adc", "rc", "esc", "telemetry"};

const char *hal_dev_name(hal_dev_t dev) { return (unsigned)dev < HAL_DEV_COUNT ? dev_names[dev] : "?"; }

const char *hal_last_error(void) { return g.error ? g.error : ""; }

static int fail(hal_dev_t dev, hal_dev_t *failed, int status, const char *why)
{
    *failed = dev;
    g.error = why;
    return status;
}

/* -- the Timer1 interrupt: captures, ESC edges, the alarm ------------------------------------ */

static void timer1_isr(void) __attribute__((interrupt("IRQ")));
static void timer1_isr(void)
{
    uint32_t ir = T1IR;
    if (ir & TIR_CR0)
        lpc_capture_isr();
    if (ir & (TIR_MR2 | TIR_MR3))
        lpc_esc_timer_isr(ir);
    T1IR = ir & (TIR_MR1 | TIR_MR2 | TIR_MR3 | TIR_CR0); /* MR1 is the alarm: waking was its job */
    VICVectAddr = 0;
}

static void spurious_isr(void) __attribute__((interrupt("IRQ")));
static void spurious_isr(void) { VICVectAddr = 0; }

static void vic_slot(uint32_t slot, uint32_t channel, void (*isr)(void))
{
    VICVectAddrN(slot) = (uint32_t)isr;
    VICVectCntlN(slot) = VIC_SLOT_ENABLE | channel;
    VICIntEnable = 1u << channel;
}

/* -- open / close ----------------------------------------------------------------------------- */

int hal_open(const hal_config_t *cfg, hal_dev_t *failed)
{
    int r;
    g.error = NULL;
    memset(&lpc_counters, 0, sizeof lpc_counters);
    VICIntEnClr = 0xFFFFFFFFu;
    VICIntSelect = 0; /* everything IRQ, nothing FIQ */
    VICDefVectAddr = (uint32_t)spurious_isr;
    PCONP |= PCONP_TIM1 | PCONP_UART0 | PCONP_UART1 | PCONP_PWM0 | PCONP_SPI0;

    /* Timer1: microseconds, free-running; MR1 the alarm, MR2/MR3 the ESC match outputs */
    T1TCR = 2;
    T1PR = PCLK_HZ / 1000000u - 1u;
    T1MCR = (1u << 3) | (1u << 6) | (1u << 9); /* interrupt on MR1, MR2, MR3; never reset */
    T1MR1 = 0xFFFFFFFFu;
    T1TCR = 1;
    g.last_tc = 0;
    g.high = 0;
    vic_slot(1, VIC_TIMER1, timer1_isr);

    if (cfg->port[HAL_DEV_IMU].enabled && (r = lpc_uart_open(HAL_UART_IMU, cfg->port[HAL_DEV_IMU].baud)) < 0)
        return fail(HAL_DEV_IMU, failed, r, "UART0: no divisor within 3 % of the baud rate");
    if (cfg->port[HAL_DEV_TELEMETRY].enabled &&
        (r = lpc_uart_open(HAL_UART_TELEMETRY, cfg->port[HAL_DEV_TELEMETRY].baud)) < 0)
        return fail(HAL_DEV_TELEMETRY, failed, r, "UART1: no divisor within 3 % of the baud rate");
    if (cfg->port[HAL_DEV_RC].enabled && cfg->rc_frontend == HAL_RC_SBUS)
        return fail(HAL_DEV_RC, failed, HAL_ERR_ABSENT, "SBUS needs a third UART; the LPC2148 has two (both taken)");
    lpc_rc_open(cfg->port[HAL_DEV_RC].enabled);
    lpc_spi_config(cfg->spi_speed_hz);
    if (cfg->port[HAL_DEV_ESC].enabled)
        lpc_esc_open();
    g.open = true;
    irq_enable();
    return HAL_OK;
}

void hal_close(void)
{
    if (!g.open)
        return;
    VICIntEnClr = 0xFFFFFFFFu;
    g.open = false;
}

/* -- time -------------------------------------------------------------------------------------- */

uint64_t lpc_now_us(void)
{
    uint32_t saved = irq_save();
    uint32_t tc = T1TC;
    if (tc < g.last_tc)
        g.high++;
    g.last_tc = tc;
    uint64_t now = ((uint64_t)g.high << 32) | tc;
    irq_restore(saved);
    return now;
}

uint64_t hal_now_ns(void) { return lpc_now_us() * 1000u; }

void lpc_alarm(uint64_t at_us)
{
    T1MR1 = (uint32_t)at_us;
    T1IR = TIR_MR1;
}

void __attribute__((noinline)) lpc_idle(void)
{
    /* the core stops after this store, until the VIC requests an interrupt */
    PCON = PCON_IDL;
}

bool lpc_wait(bool (*ready)(void *), void *arg, uint64_t deadline_us)
{
    for (;;) {
        uint32_t saved = irq_save();
        if (ready(arg)) {
            irq_restore(saved);
            return true;
        }
        uint64_t now = lpc_now_us();
        if (now >= deadline_us) {
            irq_restore(saved);
            return false;
        }
        lpc_alarm(deadline_us - now > 0xFFFFFFFFu ? now + 0xFFFFFFFFu : deadline_us);
        lpc_idle();
        irq_restore(saved); /* the request that woke the core is taken here */
    }
}

static bool never(void *arg)
{
    (void)arg;
    return false;
}

void hal_sleep_ns(uint64_t ns) { (void)lpc_wait(never, NULL, lpc_now_us() + (ns + 999u) / 1000u); }

/* -- log and stop ------------------------------------------------------------------------------- */

enum { SYS_WRITE = 0x05 };

int lpc_semihost(int op, const void *arg)
{
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("swi 0x123456" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void hal_log_line(const char *line, size_t n)
{
    uint32_t args[3] = {2u, (uint32_t)line, (uint32_t)n}; /* handle 2: the console's error stream */
    (void)lpc_semihost(SYS_WRITE, args);
    args[1] = (uint32_t)"\n";
    args[2] = 1u;
    (void)lpc_semihost(SYS_WRITE, args);
}

bool hal_stop_requested(void) { return false; }

const char *hal_stop_signal(void) { return ""; }

const hal_counters_t *hal_counters(void) { return &lpc_counters; }

/* -- faults: a message on the console, then a branch to itself (the bench sees the PC there) -- */

static void __attribute__((noreturn)) fault(const char *what)
{
    hal_log_line(what, strlen(what));
    for (;;) {
    }
}

void hal_fault_undef(void) { fault("fault: undefined instruction"); }
void hal_fault_pabort(void) { fault("fault: prefetch abort"); }
void hal_fault_dabort(void) { fault("fault: data abort"); }
void hal_fault_fiq(void) { fault("fault: FIQ (none is enabled)"); }
