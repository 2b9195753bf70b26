/*
 * Start-up code of the mkpla Cortex-M4 harness (QEMU mps2-an386). Written in assembly so that no
 * floating-point instruction can run before the FPU is enabled: Reset_Handler first grants full
 * access to coprocessors CP10 and CP11 (the FPU) in SCB->CPACR, then copies .data, zeroes .bss,
 * calls main and reports main's return value to the host through semihosting SYS_EXIT.
 */
    .syntax unified
    .cpu cortex-m4
    .thumb

    .section .vectors, "a"
    .align 2
    .global vector_table
vector_table:
    .word __stack_top           /* initial main stack pointer */
    .word Reset_Handler
    .word Fault_Handler         /* NMI */
    .word Fault_Handler         /* HardFault */
    .word Fault_Handler         /* MemManage */
    .word Fault_Handler         /* BusFault */
    .word Fault_Handler         /* UsageFault (e.g. an FP instruction with the FPU still off) */
    .word 0, 0, 0, 0
    .word Fault_Handler         /* SVCall */
    .word Fault_Handler         /* DebugMonitor */
    .word 0
    .word Fault_Handler         /* PendSV */
    .word Fault_Handler         /* SysTick */

    .text
    .thumb_func
    .global Reset_Handler
    .type Reset_Handler, %function
Reset_Handler:
    /* SCB->CPACR (0xE000ED88) |= 0xF << 20: CP10 and CP11 full access */
    ldr r0, =0xE000ED88
    ldr r1, [r0]
    orr r1, r1, #(0xF << 20)
    str r1, [r0]
    dsb
    isb
    /* .data: from its load address in code memory to SRAM */
    ldr r0, =__data_load
    ldr r1, =__data_start
    ldr r2, =__data_end
1:  cmp r1, r2
    bhs 2f
    ldr r3, [r0], #4
    str r3, [r1], #4
    b 1b
2:  /* .bss: zero */
    ldr r1, =__bss_start
    ldr r2, =__bss_end
    movs r3, #0
3:  cmp r1, r2
    bhs 4f
    str r3, [r1], #4
    b 3b
4:  bl main
    /* SYS_EXIT (0x18): ADP_Stopped_ApplicationExit (0x20026) is exit status 0 on QEMU, anything
     * else (ADP_Stopped_RunTimeErrorUnknown, 0x20023) status 1 */
    cmp r0, #0
    ite eq
    ldreq r1, =0x20026
    ldrne r1, =0x20023
    movs r0, #0x18
    bkpt 0xab
5:  b 5b
    .size Reset_Handler, . - Reset_Handler

    .thumb_func
    .type Fault_Handler, %function
Fault_Handler:
    ldr r1, =0x20023
    movs r0, #0x18
    bkpt 0xab
6:  b 6b
    .size Fault_Handler, . - Fault_Handler
    .pool
