/*
 * hal_uart.c - UART0 (the XSENS) and UART1 (the XBee) with ring buffers the interrupt handlers
 * fill and drain (UM10139 chapters 10 and 11: 16550-style, 16-byte FIFOs).
 *
 * Receive: the RX FIFO interrupts at 8 characters (RDA) and on the character timeout (CTI);
 * the handler takes what the FIFO holds into the ring. A byte lost to a full FIFO (LSR.OE, the
 * handler was late) or to a full ring counts in uart_overruns. Transmit: hal_uart_write queues
 * into the ring and fills an empty transmitter at once; the THRE interrupt sends the rest, 16
 * bytes a time. The baud rate takes the fractional divider (U0FDR/U1FDR) nearest the asked
 * rate.
 */
#include <string.h>

#include "hal.h"
#include "lpc2148.h"
#include "lpc_internal.h"

#define RX_SIZE 512u /* powers of two: the IMU's 69-byte samples, the modem's commands */
#define TX_SIZE 256u /* the telemetry's frames (the writer checks the room first) */

typedef struct {
    uint32_t base;
    bool open;
    volatile uint16_t rx_head, rx_tail, tx_head, tx_tail;
    uint8_t rx[RX_SIZE];
    uint8_t tx[TX_SIZE];
} uart_t;

static uart_t g_uart[2]; /* zeroed (.bss): the bases are set at open */
static const uint32_t uart_base[2] = {UART0_BASE, UART1_BASE};

static uart_t *uart_of(hal_uart_t u) { return (u == HAL_UART_IMU || u == HAL_UART_TELEMETRY) ? &g_uart[u] : NULL; }

/* The divisor and fractional divider nearest baud (UM10139 10.4.12):
 * baud = PCLK x MUL / (16 x DL x (MUL + DIVADD)), DIVADD < MUL, DL >= 3 with DIVADD > 0. */
static int set_baud(uint32_t base, uint32_t baud)
{
    uint32_t best_dl = 0, best_add = 0, best_mul = 1;
    uint64_t best_ppm = UINT64_MAX; /* the rate's error, parts per million */
    for (uint32_t mul = 1; mul <= 15; mul++) {
        for (uint32_t add = 0; add < mul; add++) {
            uint64_t unit = 16ull * baud * (mul + add);
            uint64_t dl = ((uint64_t)PCLK_HZ * mul + unit / 2) / unit;
            if (dl < 1 || dl > 0xFFFF || (add && dl < 3))
                continue;
            uint64_t den = unit * dl, num = (uint64_t)PCLK_HZ * mul;
            uint64_t ppm = (num > den ? num - den : den - num) * 1000000u / den;
            if (ppm < best_ppm) {
                best_ppm = ppm;
                best_dl = (uint32_t)dl, best_add = add, best_mul = mul;
            }
        }
    }
    if (best_ppm > 30000u)
        return HAL_ERR_CONFIG;
    UxLCR(base) = LCR_8N1 | LCR_DLAB;
    UxDLL(base) = best_dl & 0xFFu;
    UxDLM(base) = best_dl >> 8;
    UxLCR(base) = LCR_8N1;
    UxFDR(base) = (best_mul << 4) | best_add;
    return HAL_OK;
}

int lpc_uart_open(hal_uart_t u, uint32_t baud)
{
    uart_t *p = uart_of(u);
    if (!p)
        return HAL_ERR_ABSENT;
    uint32_t base = uart_base[u == HAL_UART_IMU ? 0 : 1];
    p->base = base;
    if (u == HAL_UART_IMU)
        PINSEL0 = (PINSEL0 & ~0xFu) | 0x5u; /* P0.0 TXD0, P0.1 RXD0 */
    else
        PINSEL0 = (PINSEL0 & ~0xF0000u) | 0x50000u; /* P0.8 TXD1, P0.9 RXD1 */
    if (set_baud(base, baud) < 0)
        return HAL_ERR_CONFIG;
    UxFCR(base) = FCR_ENABLE | FCR_RX_RESET | FCR_TX_RESET | FCR_TRIGGER_8;
    p->rx_head = p->rx_tail = p->tx_head = p->tx_tail = 0;
    UxIER(base) = IER_RBR | IER_RLS;
    p->open = true;
    /* VIC slot 0: the IMU's UART (the highest priority), slot 2: the modem's */
    VICVectAddrN(u == HAL_UART_IMU ? 0u : 2u) = (uint32_t)(u == HAL_UART_IMU ? lpc_uart_isr0 : lpc_uart_isr1);
    VICVectCntlN(u == HAL_UART_IMU ? 0u : 2u) = VIC_SLOT_ENABLE | (u == HAL_UART_IMU ? VIC_UART0 : VIC_UART1);
    VICIntEnable = 1u << (u == HAL_UART_IMU ? VIC_UART0 : VIC_UART1);
    return HAL_OK;
}

/* -- the interrupt handlers ---------------------------------------------------------------- */

static void rx_byte(uart_t *p, hal_uart_t u, uint8_t b)
{
    uint16_t next = (uint16_t)((p->rx_head + 1u) & (RX_SIZE - 1u));
    if (next == p->rx_tail) {
        lpc_counters.uart_overruns[u]++;
        return;
    }
    p->rx[p->rx_head] = b;
    p->rx_head = next;
}

static void tx_fill(uart_t *p)
{
    uint32_t n = 0;
    while (p->tx_tail != p->tx_head && n < UART_FIFO) {
        UxTHR(p->base) = p->tx[p->tx_tail];
        p->tx_tail = (uint16_t)((p->tx_tail + 1u) & (TX_SIZE - 1u));
        n++;
    }
    if (p->tx_tail == p->tx_head)
        UxIER(p->base) &= ~IER_THRE;
    else
        UxIER(p->base) |= IER_THRE;
}

static void uart_isr(hal_uart_t u)
{
    uart_t *p = &g_uart[u];
    uint32_t base = p->base;
    for (;;) {
        uint32_t iir = UxIIR(base);
        if (iir & IIR_NONE)
            break;
        switch (iir & IIR_ID_MASK) {
        case IIR_RDA: /* at least the trigger level waits: take it without asking LSR */
            for (uint32_t i = 0; i < UART_RX_TRIGGER - 1u; i++)
                rx_byte(p, u, (uint8_t)UxRBR(base));
            /* fall through */
        case IIR_CTI: /* the rest, by LSR.RDR */
        case IIR_RLS:
            for (;;) {
                uint32_t lsr = UxLSR(base);
                if (lsr & LSR_OE)
                    lpc_counters.uart_overruns[u]++;
                if (!(lsr & LSR_RDR))
                    break;
                rx_byte(p, u, (uint8_t)UxRBR(base));
            }
            break;
        case IIR_THRE:
            tx_fill(p);
            break;
        default:
            break;
        }
    }
    VICVectAddr = 0;
}

void lpc_uart_isr0(void) { uart_isr(HAL_UART_IMU); }
void lpc_uart_isr1(void) { uart_isr(HAL_UART_TELEMETRY); }

/* -- the API ------------------------------------------------------------------------------- */

static uint32_t rx_count(const uart_t *p) { return (uint32_t)(p->rx_head - p->rx_tail) & (RX_SIZE - 1u); }

static bool rx_ready(void *arg) { return rx_count(arg) > 0; }

int32_t hal_uart_read(hal_uart_t u, uint8_t *buf, size_t max, uint64_t timeout_ns)
{
    uart_t *p = uart_of(u);
    if (!p)
        return HAL_ERR_ABSENT;
    if (!p->open)
        return HAL_ERR_IO;
    if (max == 0)
        return 0;
    if (!rx_ready(p) && (timeout_ns == 0 || !lpc_wait(rx_ready, p, lpc_now_us() + (timeout_ns + 999u) / 1000u)))
        return 0;
    uint32_t n = rx_count(p);
    if (n > max)
        n = (uint32_t)max;
    for (uint32_t i = 0; i < n; i++) {
        buf[i] = p->rx[p->rx_tail];
        p->rx_tail = (uint16_t)((p->rx_tail + 1u) & (RX_SIZE - 1u));
    }
    return (int32_t)n;
}

int32_t hal_uart_write(hal_uart_t u, const uint8_t *data, size_t n)
{
    uart_t *p = uart_of(u);
    if (!p)
        return HAL_ERR_ABSENT;
    if (!p->open)
        return HAL_ERR_IO;
    uint32_t saved = irq_save();
    size_t taken = 0;
    while (taken < n) {
        uint16_t next = (uint16_t)((p->tx_head + 1u) & (TX_SIZE - 1u));
        if (next == p->tx_tail)
            break;
        p->tx[p->tx_head] = data[taken++];
        p->tx_head = next;
    }
    if (!(UxIER(p->base) & IER_THRE) && (UxLSR(p->base) & LSR_THRE))
        tx_fill(p); /* the transmitter is idle: start it; THRE interrupts send the rest */
    else
        UxIER(p->base) |= IER_THRE;
    irq_restore(saved);
    return (int32_t)taken;
}

int32_t hal_uart_in_waiting(hal_uart_t u)
{
    uart_t *p = uart_of(u);
    if (!p)
        return HAL_ERR_ABSENT;
    return p->open ? (int32_t)rx_count(p) : HAL_ERR_IO;
}

int32_t hal_uart_out_waiting(hal_uart_t u)
{
    uart_t *p = uart_of(u);
    if (!p)
        return HAL_ERR_ABSENT;
    return p->open ? (int32_t)((uint32_t)(p->tx_head - p->tx_tail) & (TX_SIZE - 1u)) : HAL_ERR_IO;
}

void hal_uart_flush_input(hal_uart_t u)
{
    uart_t *p = uart_of(u);
    if (!p || !p->open)
        return;
    uint32_t saved = irq_save();
    UxFCR(p->base) = FCR_ENABLE | FCR_RX_RESET | FCR_TRIGGER_8;
    p->rx_tail = p->rx_head;
    irq_restore(saved);
}
