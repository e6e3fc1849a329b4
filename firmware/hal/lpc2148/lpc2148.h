/*
 * lpc2148.h - the NXP LPC2148 registers the hardware layer uses (UM10139, LPC214x user manual,
 * Rev. 4: the register map of each chapter), and the board's pin map.
 *
 * Pins (P0, PINSEL0/1 functions; a PWM channel shares its pin with a UART on this part: PWM1/3
 * sit on UART0's P0.0/P0.1 and PWM4/6 on UART1's P0.8/P0.9, so with both UARTs in use only
 * PWM2 and PWM5 reach a pin; the other two ESCs take Timer1's match outputs):
 *
 *   P0.0  TXD0   XSENS               P0.1  RXD0   XSENS
 *   P0.8  TXD1   XBee                P0.9  RXD1   XBee
 *   P0.4  SCK0   MCP3204 CLK         P0.5  MISO0  MCP3204 DOUT
 *   P0.6  MOSI0  MCP3204 DIN         P0.20 GPIO   MCP3204 /CS (high when idle)
 *   P0.7  PWM2   ESC 0               P0.21 PWM5   ESC 1
 *   P0.17 MAT1.2 ESC 2               P0.18 MAT1.3 ESC 3
 *   P0.10 CAP1.0 PPM receiver
 *
 * Clocks: 12 MHz crystal, PLL to CCLK = 60 MHz, PCLK = CCLK (VPBDIV = 1), MAM fully on with
 * 3-cycle flash (startup.S). Timer1 counts microseconds (PR = 59): the time base, the PPM
 * captures and the match-output ESC pulses.
 */
#ifndef FW_LPC2148_H
#define FW_LPC2148_H

#include <stdint.h>

#define REG32(addr) (*(volatile uint32_t *)(addr))

#define FOSC_HZ 12000000u
#define CCLK_HZ 60000000u
#define PCLK_HZ CCLK_HZ

/* -- system control (UM10139 chapter 4), 0xE01F C000 ------------------------------------- */
#define MAMCR REG32(0xE01FC000)
#define MAMTIM REG32(0xE01FC004)
#define MEMMAP REG32(0xE01FC040)
#define PLL0CON REG32(0xE01FC080)
#define PLL0CFG REG32(0xE01FC084)
#define PLL0STAT REG32(0xE01FC088)
#define PLL0FEED REG32(0xE01FC08C)
#define PCON REG32(0xE01FC0C0)
#define PCONP REG32(0xE01FC0C4)
#define VPBDIV REG32(0xE01FC100)

#define PCON_IDL 0x01u
#define PCONP_TIM1 (1u << 2)
#define PCONP_UART0 (1u << 3)
#define PCONP_UART1 (1u << 4)
#define PCONP_PWM0 (1u << 5)
#define PCONP_SPI0 (1u << 8)

/* -- pin connect block (chapter 7) --------------------------------------------------------- */
#define PINSEL0 REG32(0xE002C000)
#define PINSEL1 REG32(0xE002C004)

/* -- legacy GPIO (chapter 8) --------------------------------------------------------------- */
#define IO0PIN REG32(0xE0028000)
#define IO0SET REG32(0xE0028004)
#define IO0DIR REG32(0xE0028008)
#define IO0CLR REG32(0xE002800C)

/* -- UART0 / UART1 (chapters 10, 11) ------------------------------------------------------- */
#define UART0_BASE 0xE000C000u
#define UART1_BASE 0xE0010000u
#define UxRBR(b) REG32((b) + 0x00u) /* DLAB = 0, read */
#define UxTHR(b) REG32((b) + 0x00u) /* DLAB = 0, write */
#define UxDLL(b) REG32((b) + 0x00u) /* DLAB = 1 */
#define UxIER(b) REG32((b) + 0x04u)
#define UxDLM(b) REG32((b) + 0x04u) /* DLAB = 1 */
#define UxIIR(b) REG32((b) + 0x08u)
#define UxFCR(b) REG32((b) + 0x08u)
#define UxLCR(b) REG32((b) + 0x0Cu)
#define UxLSR(b) REG32((b) + 0x14u)
#define UxFDR(b) REG32((b) + 0x28u)
#define UxTER(b) REG32((b) + 0x30u)

#define LSR_RDR 0x01u
#define LSR_OE 0x02u
#define LSR_THRE 0x20u
#define IER_RBR 0x01u
#define IER_THRE 0x02u
#define IER_RLS 0x04u
#define IIR_NONE 0x01u
#define IIR_ID_MASK 0x0Eu
#define IIR_RLS 0x06u
#define IIR_RDA 0x04u
#define IIR_CTI 0x0Cu
#define IIR_THRE 0x02u
#define LCR_8N1 0x03u
#define LCR_DLAB 0x80u
#define FCR_ENABLE 0x01u
#define FCR_RX_RESET 0x02u
#define FCR_TX_RESET 0x04u
#define FCR_TRIGGER_8 0x80u /* RX trigger level 2: 8 characters */
#define UART_RX_TRIGGER 8u
#define UART_FIFO 16u

/* -- SPI0 (chapter 12) --------------------------------------------------------------------- */
#define S0SPCR REG32(0xE0020000)
#define S0SPSR REG32(0xE0020004)
#define S0SPDR REG32(0xE0020008)
#define S0SPCCR REG32(0xE002000C)
#define SPCR_MSTR 0x20u
#define SPSR_SPIF 0x80u
#define SPSR_ERRORS 0x78u /* ABRT, MODF, ROVR, WCOL */

/* -- Timer1 (chapter 15) ------------------------------------------------------------------- */
#define T1IR REG32(0xE0008000)
#define T1TCR REG32(0xE0008004)
#define T1TC REG32(0xE0008008)
#define T1PR REG32(0xE000800C)
#define T1MCR REG32(0xE0008014)
#define T1MR0 REG32(0xE0008018)
#define T1MR1 REG32(0xE000801C)
#define T1MR2 REG32(0xE0008020)
#define T1MR3 REG32(0xE0008024)
#define T1CCR REG32(0xE0008028)
#define T1CR0 REG32(0xE000802C)
#define T1EMR REG32(0xE000803C)
#define TIR_MR1 0x02u
#define TIR_MR2 0x04u
#define TIR_MR3 0x08u
#define TIR_CR0 0x10u

/* -- PWM (chapter 16) ---------------------------------------------------------------------- */
#define PWMIR REG32(0xE0014000)
#define PWMTCR REG32(0xE0014004)
#define PWMPR REG32(0xE001400C)
#define PWMMCR REG32(0xE0014014)
#define PWMMR0 REG32(0xE0014018)
#define PWMMR2 REG32(0xE0014020)
#define PWMMR5 REG32(0xE0014044)
#define PWMPCR REG32(0xE001404C)
#define PWMLER REG32(0xE0014050)

/* -- VIC (chapter 5), 0xFFFF F000 --------------------------------------------------------- */
#define VICIntSelect REG32(0xFFFFF00C)
#define VICIntEnable REG32(0xFFFFF010)
#define VICIntEnClr REG32(0xFFFFF014)
#define VICVectAddr REG32(0xFFFFF030)
#define VICDefVectAddr REG32(0xFFFFF034)
#define VICVectAddrN(n) REG32(0xFFFFF100u + 4u * (n))
#define VICVectCntlN(n) REG32(0xFFFFF200u + 4u * (n))
#define VIC_SLOT_ENABLE 0x20u

/* VIC channels */
#define VIC_TIMER1 5u
#define VIC_UART0 6u
#define VIC_UART1 7u

#endif /* FW_LPC2148_H */
