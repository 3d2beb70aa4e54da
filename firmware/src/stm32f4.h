/* The few STM32F4 / Cortex-M4 registers this firmware touches (RM0383 for the F411,
 * RM0090 for the F405, ARMv7-M ARM). Written here instead of pulling in a vendor HAL. */
#ifndef EDDI_STM32F4_H
#define EDDI_STM32F4_H

#include <stdint.h>

#define REG32(addr) (*(volatile uint32_t *)(uintptr_t)(addr))

/* Cortex-M4 core */
#define SYST_CSR REG32(0xE000E010u)
#define SYST_RVR REG32(0xE000E014u)
#define SYST_CVR REG32(0xE000E018u)
#define NVIC_ISER(n) REG32(0xE000E100u + 4u * (n))
#define NVIC_IPR(n) (*(volatile uint8_t *)(uintptr_t)(0xE000E400u + (n)))
#define SCB_CPACR REG32(0xE000ED88u)
#define SCB_VTOR REG32(0xE000ED08u)

/* RCC */
#define RCC_BASE 0x40023800u
#define RCC_CR REG32(RCC_BASE + 0x00u)
#define RCC_PLLCFGR REG32(RCC_BASE + 0x04u)
#define RCC_CFGR REG32(RCC_BASE + 0x08u)
#define RCC_AHB1ENR REG32(RCC_BASE + 0x30u)
#define RCC_AHB2ENR REG32(RCC_BASE + 0x34u)
#define RCC_APB1ENR REG32(RCC_BASE + 0x40u)
#define RCC_APB2ENR REG32(RCC_BASE + 0x44u)
#define FLASH_ACR REG32(0x40023C00u)

/* GPIO */
#define GPIOA_BASE 0x40020000u
#define GPIOB_BASE 0x40020400u
#define GPIO_MODER(b) REG32((b) + 0x00u)
#define GPIO_OTYPER(b) REG32((b) + 0x04u)
#define GPIO_OSPEEDR(b) REG32((b) + 0x08u)
#define GPIO_PUPDR(b) REG32((b) + 0x0Cu)
#define GPIO_IDR(b) REG32((b) + 0x10u)
#define GPIO_BSRR(b) REG32((b) + 0x18u)
#define GPIO_AFRL(b) REG32((b) + 0x20u)
#define GPIO_AFRH(b) REG32((b) + 0x24u)

/* USART1 */
#define USART1_BASE 0x40011000u
#define USART_SR(b) REG32((b) + 0x00u)
#define USART_DR(b) REG32((b) + 0x04u)
#define USART_BRR(b) REG32((b) + 0x08u)
#define USART_CR1(b) REG32((b) + 0x0Cu)
#define USART_SR_RXNE (1u << 5)
#define USART_SR_TXE (1u << 7)
#define USART_CR1_UE (1u << 13)
#define USART_CR1_TE (1u << 3)
#define USART_CR1_RE (1u << 2)
#define USART_CR1_RXNEIE (1u << 5)
#define USART1_IRQn 37u

/* SPI1 */
#define SPI1_BASE 0x40013000u
#define SPI_CR1(b) REG32((b) + 0x00u)
#define SPI_SR(b) REG32((b) + 0x08u)
#define SPI_DR(b) REG32((b) + 0x0Cu)
#define SPI_SR_RXNE (1u << 0)
#define SPI_SR_TXE (1u << 1)
#define SPI_SR_BSY (1u << 7)

/* TIM1 (ADC master clock) */
#define TIM1_BASE 0x40010000u
#define TIM_CR1(b) REG32((b) + 0x00u)
#define TIM_EGR(b) REG32((b) + 0x14u)
#define TIM_CCMR1(b) REG32((b) + 0x18u)
#define TIM_CCER(b) REG32((b) + 0x20u)
#define TIM_PSC(b) REG32((b) + 0x28u)
#define TIM_ARR(b) REG32((b) + 0x2Cu)
#define TIM_CCR1(b) REG32((b) + 0x34u)
#define TIM_BDTR(b) REG32((b) + 0x44u)

#define TIM2_BASE 0x40000000u
#define TIM_CNT(b) REG32((b) + 0x24u)

/* EXTI / SYSCFG (ADC data-ready line) */
#define EXTI_IMR REG32(0x40013C00u)
#define EXTI_FTSR REG32(0x40013C0Cu)
#define EXTI_PR REG32(0x40013C14u)
#define SYSCFG_EXTICR1 REG32(0x40013808u)

/* USB OTG FS */
#define OTG_BASE 0x50000000u
#define OTG_GAHBCFG REG32(OTG_BASE + 0x008u)
#define OTG_GUSBCFG REG32(OTG_BASE + 0x00Cu)
#define OTG_GRSTCTL REG32(OTG_BASE + 0x010u)
#define OTG_GINTSTS REG32(OTG_BASE + 0x014u)
#define OTG_GINTMSK REG32(OTG_BASE + 0x018u)
#define OTG_GRXSTSP REG32(OTG_BASE + 0x020u)
#define OTG_GRXFSIZ REG32(OTG_BASE + 0x024u)
#define OTG_DIEPTXF0 REG32(OTG_BASE + 0x028u)
#define OTG_GCCFG REG32(OTG_BASE + 0x038u)
#define OTG_DIEPTXF(n) REG32(OTG_BASE + 0x104u + 4u * ((n) - 1u))
#define OTG_DCFG REG32(OTG_BASE + 0x800u)
#define OTG_DCTL REG32(OTG_BASE + 0x804u)
#define OTG_DIEPMSK REG32(OTG_BASE + 0x810u)
#define OTG_DOEPMSK REG32(OTG_BASE + 0x814u)
#define OTG_DAINT REG32(OTG_BASE + 0x818u)
#define OTG_DAINTMSK REG32(OTG_BASE + 0x81Cu)
#define OTG_DIEPCTL(n) REG32(OTG_BASE + 0x900u + 0x20u * (n))
#define OTG_DIEPINT(n) REG32(OTG_BASE + 0x908u + 0x20u * (n))
#define OTG_DIEPTSIZ(n) REG32(OTG_BASE + 0x910u + 0x20u * (n))
#define OTG_DTXFSTS(n) REG32(OTG_BASE + 0x918u + 0x20u * (n))
#define OTG_DOEPCTL(n) REG32(OTG_BASE + 0xB00u + 0x20u * (n))
#define OTG_DOEPINT(n) REG32(OTG_BASE + 0xB08u + 0x20u * (n))
#define OTG_DOEPTSIZ(n) REG32(OTG_BASE + 0xB10u + 0x20u * (n))
#define OTG_PCGCCTL REG32(OTG_BASE + 0xE00u)
#define OTG_FIFO(n) REG32(OTG_BASE + 0x1000u * ((n) + 1u))

/* Interrupt handlers a board may define (startup.c gives weak defaults). */
void SysTick_Handler(void);
void EXTI0_IRQHandler(void);
void OTG_FS_IRQHandler(void);
void USART1_IRQHandler(void);
void Reset_Handler(void);
void Default_Handler(void);

#endif
