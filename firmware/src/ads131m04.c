/* ADS131M04 driver (datasheet SBAS890): SPI mode 1, 24-bit words, a frame per conversion of
 * STATUS, four channel words and a CRC word (18 bytes). The ADC's master clock (CLKIN) is
 * TIM1 CH1 on PA8: 96 MHz / 12 = 8.000 MHz, so the modulator runs at 4 MHz and the data rate
 * is 4 MHz / OSR (3906.25 Hz at OSR 1024). DRDY (PB0, falling edge, EXTI0) starts each read.
 *
 * Wiring (docs/hardware.md): PA4 /CS, PA5 SCLK, PA6 DOUT (MISO), PA7 DIN (MOSI), PA8 CLKIN,
 * PB0 /DRDY, PB1 /SYNC-/RESET.
 */
#include "ads131m04.h"

#include "stm32f4.h"

#define CS_PIN 4u
#define RESET_PIN 1u
#define REG_MODE 0x02u
#define REG_CLOCK 0x03u
#define REG_GAIN1 0x04u

static void cs(int low)
{
    GPIO_BSRR(GPIOA_BASE) = low ? 1u << (CS_PIN + 16u) : 1u << CS_PIN;
}

static uint8_t spi_byte(uint8_t out)
{
    while (!(SPI_SR(SPI1_BASE) & SPI_SR_TXE)) {
    }
    SPI_DR(SPI1_BASE) = out;
    while (!(SPI_SR(SPI1_BASE) & SPI_SR_RXNE)) {
    }
    return (uint8_t)SPI_DR(SPI1_BASE);
}

/* One frame: `words` 24-bit words out (command first, then zeros), words in. */
static void frame(const uint32_t *out, unsigned n_out, uint32_t *in, unsigned words)
{
    cs(1);
    for (unsigned w = 0; w < words; w++) {
        uint32_t o = w < n_out ? out[w] : 0u;
        uint32_t v = 0;
        for (int b = 2; b >= 0; b--)
            v = (v << 8) | spi_byte((uint8_t)(o >> (8 * b)));
        if (in)
            in[w] = v;
    }
    while (SPI_SR(SPI1_BASE) & SPI_SR_BSY) {
    }
    cs(0);
}

static void write_reg(unsigned addr, uint16_t value)
{
    uint32_t out[2] = {(uint32_t)(0x6000u | (addr << 7)) << 8, (uint32_t)value << 8};
    frame(out, 2, 0, 7);
}

static void delay(volatile uint32_t n)
{
    while (n--) {
    }
}

void ads_init(void)
{
    RCC_AHB1ENR |= (1u << 0) | (1u << 1);              /* GPIOA, GPIOB */
    RCC_APB2ENR |= (1u << 0) | (1u << 12) | (1u << 14); /* TIM1, SPI1, SYSCFG */
    /* PA4 output (CS, high); PA5-7 AF5 (SPI1); PA8 AF1 (TIM1_CH1) */
    GPIO_BSRR(GPIOA_BASE) = 1u << CS_PIN;
    GPIO_MODER(GPIOA_BASE) = (GPIO_MODER(GPIOA_BASE) & ~(0x3FFu << 8)) | (0x2A9u << 8);
    GPIO_OSPEEDR(GPIOA_BASE) |= 0x3FFu << 8;
    GPIO_AFRL(GPIOA_BASE) = (GPIO_AFRL(GPIOA_BASE) & ~(0xFFFu << 20)) | (0x555u << 20);
    GPIO_AFRH(GPIOA_BASE) = (GPIO_AFRH(GPIOA_BASE) & ~0xFu) | 0x1u;
    /* PB0 input pull-up (DRDY), PB1 output high (SYNC/RESET) */
    GPIO_MODER(GPIOB_BASE) = (GPIO_MODER(GPIOB_BASE) & ~0xFu) | (0x1u << 2);
    GPIO_PUPDR(GPIOB_BASE) = (GPIO_PUPDR(GPIOB_BASE) & ~0x3u) | 0x1u;
    GPIO_BSRR(GPIOB_BASE) = 1u << RESET_PIN;
    /* CLKIN: TIM1 CH1 PWM, 8 MHz, 50 % */
    TIM_PSC(TIM1_BASE) = 0;
    TIM_ARR(TIM1_BASE) = 11;
    TIM_CCR1(TIM1_BASE) = 6;
    TIM_CCMR1(TIM1_BASE) = (6u << 4) | (1u << 3);
    TIM_CCER(TIM1_BASE) = 1u;
    TIM_BDTR(TIM1_BASE) = 1u << 15;
    TIM_EGR(TIM1_BASE) = 1u;
    TIM_CR1(TIM1_BASE) = 1u;
    /* SPI1: master, mode 1 (CPOL 0, CPHA 1), 96 MHz / 8 = 12 MHz, software NSS */
    SPI_CR1(SPI1_BASE) = (1u << 2) | (2u << 3) | (1u << 0) | (1u << 9) | (1u << 8) | (1u << 6);
    /* DRDY on EXTI0 from port B, falling edge */
    SYSCFG_EXTICR1 = (SYSCFG_EXTICR1 & ~0xFu) | 0x1u;
    EXTI_FTSR |= 1u;
    NVIC_IPR(6) = 0x40u;
    NVIC_ISER(0) = 1u << 6;
    /* reset pulse (> 2048 CLKIN periods), then wait for the ADC to come up */
    GPIO_BSRR(GPIOB_BASE) = 1u << (RESET_PIN + 16u);
    delay(20000);
    GPIO_BSRR(GPIOB_BASE) = 1u << RESET_PIN;
    delay(20000);
    write_reg(REG_MODE, 0x0510u);                      /* reset value: 24-bit words, DRDY active low */
    write_reg(REG_GAIN1, 0x0000u);                     /* PGA gain 1 on every channel: +-1.2 V */
}

void ads_configure(unsigned osr_code)
{
    ads_stop();
    /* all four channels on, OSR, high-resolution power mode */
    write_reg(REG_CLOCK, (uint16_t)((0xFu << 8) | ((osr_code & 7u) << 2) | 0x2u));
}

void ads_start(void)
{
    EXTI_PR = 1u;
    EXTI_IMR |= 1u;
}

void ads_stop(void)
{
    EXTI_IMR &= ~1u;
}

void EXTI0_IRQHandler(void)
{
    EXTI_PR = 1u;
    uint32_t w[6];
    frame(0, 0, w, 6);
    int32_t counts[ADS_CHANNELS];
    for (unsigned c = 0; c < ADS_CHANNELS; c++)
        counts[c] = (int32_t)(w[1u + c] << 8) >> 8;    /* sign-extend 24 bits */
    ads_on_sample(counts);
}
