/* Reset handler and vector table (no vendor startup code). */
#include <stdint.h>
#include <string.h>

#include "stm32f4.h"

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

void SysTick_Handler(void) __attribute__((weak, alias("Default_Handler")));
void EXTI0_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void OTG_FS_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));
void USART1_IRQHandler(void) __attribute__((weak, alias("Default_Handler")));

void Default_Handler(void)
{
    for (;;) {
    }
}

void Reset_Handler(void)
{
    memcpy(&_sdata, &_sidata, (size_t)((uintptr_t)&_edata - (uintptr_t)&_sdata));
    memset(&_sbss, 0, (size_t)((uintptr_t)&_ebss - (uintptr_t)&_sbss));
    SCB_CPACR |= 0xFu << 20;             /* CP10, CP11: the FPU */
    __asm volatile("dsb\n isb" ::: "memory");
    main();
    for (;;) {
    }
}

#define N_VECTORS (16u + 98u)
typedef void (*vector)(void);

__attribute__((section(".isr_vector"), used)) static const vector vectors[N_VECTORS] = {
    [0] = (vector)(uintptr_t)&_estack,
    [1] = Reset_Handler,
    [2] = Default_Handler,              /* NMI */
    [3] = Default_Handler,              /* HardFault */
    [4] = Default_Handler,              /* MemManage */
    [5] = Default_Handler,              /* BusFault */
    [6] = Default_Handler,              /* UsageFault */
    [11] = Default_Handler,             /* SVCall */
    [14] = Default_Handler,             /* PendSV */
    [15] = SysTick_Handler,
    [16 + 6] = EXTI0_IRQHandler,
    [16 + 37] = USART1_IRQHandler,
    [16 + 67] = OTG_FS_IRQHandler,
};
