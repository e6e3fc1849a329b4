/*
 * startup.S - the LPC2148 from reset to main (UM10139: chapter 3 for the vectors, chapter 4
 * for the PLL, MAM and VPB divider).
 *
 *   1. the MAM fully on with 3-cycle flash fetches (MAMCR = 0, MAMTIM = 3, MAMCR = 2);
 *   2. PLL0 from the 12 MHz crystal to 60 MHz: M = 5, P = 2 (Fcco = 240 MHz), each write
 *      confirmed by the feed sequence, connected once PLOCK is set;
 *   3. PCLK = CCLK (VPBDIV = 1);
 *   4. a stack per mode, the whole stack region painted with STACK_PAINT first;
 *   5. .data copied from flash, .bss zeroed;
 *   6. main in supervisor mode with IRQ and FIQ still masked (hal_open unmasks them once the
 *      VIC is set up). If main returns, semihosting SYS_EXIT, then a branch to itself.
 *
 * The vector at 0x14 is left 0: a flash tool (lpc21isp) writes the checksum the boot loader
 * wants there. IRQs go through the VIC: the IRQ vector loads the PC from VICVectAddr.
 */
    .syntax unified
    .arm

    .equ MODE_USR, 0x10
    .equ MODE_FIQ, 0x11
    .equ MODE_IRQ, 0x12
    .equ MODE_SVC, 0x13
    .equ MODE_ABT, 0x17
    .equ MODE_UND, 0x1B
    .equ I_BIT, 0x80
    .equ F_BIT, 0x40
    .equ STACK_PAINT, 0xDEADBEEF

    .equ SCB, 0xE01FC000
    .equ MAMCR_OFS, 0x000
    .equ MAMTIM_OFS, 0x004
    .equ PLL0CON_OFS, 0x080
    .equ PLL0CFG_OFS, 0x084
    .equ PLL0STAT_OFS, 0x088
    .equ PLL0FEED_OFS, 0x08C
    .equ VPBDIV_OFS, 0x100
    .equ PLOCK, 0x400
    .equ PLL_M5_P2, 0x24          @ MSEL = 4 (M = 5), PSEL = 1 (P = 2)

    .section .vectors, "ax"
    .global _vectors
_vectors:
    ldr pc, reset_addr
    ldr pc, undef_addr
    ldr pc, swi_addr
    ldr pc, pabort_addr
    ldr pc, dabort_addr
    .word 0                         @ the boot loader's checksum
    ldr pc, [pc, #-0xFF0]           @ IRQ: VICVectAddr
    ldr pc, fiq_addr

reset_addr:  .word _reset
undef_addr:  .word hal_fault_undef
swi_addr:    .word swi_return
pabort_addr: .word hal_fault_pabort
dabort_addr: .word hal_fault_dabort
fiq_addr:    .word hal_fault_fiq

    .text
    .global _reset
    .type _reset, %function
_reset:
    ldr r0, =SCB
    mov r1, #0
    str r1, [r0, #MAMCR_OFS]
    mov r1, #3
    str r1, [r0, #MAMTIM_OFS]
    mov r1, #2
    str r1, [r0, #MAMCR_OFS]

    mov r1, #PLL_M5_P2
    str r1, [r0, #PLL0CFG_OFS]
    mov r1, #1                      @ enable
    str r1, [r0, #PLL0CON_OFS]
    bl pll_feed
1:  ldr r1, [r0, #PLL0STAT_OFS]
    tst r1, #PLOCK
    beq 1b
    mov r1, #3                      @ enable and connect
    str r1, [r0, #PLL0CON_OFS]
    bl pll_feed

    mov r1, #1
    str r1, [r0, #VPBDIV_OFS]

    @ paint the stack region, then give each mode its stack
    ldr r0, =__stack_bottom
    ldr r1, =__stack_region_end
    ldr r2, =STACK_PAINT
2:  cmp r0, r1
    strlo r2, [r0], #4
    blo 2b

    msr cpsr_c, #MODE_UND | I_BIT | F_BIT
    ldr sp, =__und_stack_top
    msr cpsr_c, #MODE_ABT | I_BIT | F_BIT
    ldr sp, =__abt_stack_top
    msr cpsr_c, #MODE_FIQ | I_BIT | F_BIT
    ldr sp, =__fiq_stack_top
    msr cpsr_c, #MODE_IRQ | I_BIT | F_BIT
    ldr sp, =__irq_stack_top
    msr cpsr_c, #MODE_SVC | I_BIT | F_BIT
    ldr sp, =__svc_stack_top

    @ .data from its load address in flash
    ldr r0, =__data_load
    ldr r1, =__data_start
    ldr r2, =__data_end
3:  cmp r1, r2
    ldrlo r3, [r0], #4
    strlo r3, [r1], #4
    blo 3b

    @ .bss to zero
    ldr r1, =__bss_start
    ldr r2, =__bss_end
    mov r3, #0
4:  cmp r1, r2
    strlo r3, [r1], #4
    blo 4b

    mov fp, #0
    bl main

    mov r0, #0x18                   @ semihosting SYS_EXIT
    ldr r1, =0x20026                @ ADP_Stopped_ApplicationExit
    swi 0x123456
5:  b 5b
    .size _reset, . - _reset

@ SWI: the firmware's only SWIs are semihosting calls, which a debugger (or the bench) serves
@ before the vector is taken; without one they return at once
    .type swi_return, %function
swi_return:
    movs pc, lr
    .size swi_return, . - swi_return

    .type pll_feed, %function
pll_feed:
    mov r2, #0xAA
    str r2, [r0, #PLL0FEED_OFS]
    mov r2, #0x55
    str r2, [r0, #PLL0FEED_OFS]
    bx lr
    .size pll_feed, . - pll_feed
