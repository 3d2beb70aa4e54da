/* Board: WeAct "Black Pill" STM32F411CEU6 (25 MHz crystal) + TI ADS131M04, USB CDC to the host.
 * Untested on hardware in this repository's CI (it builds with -Werror; see docs/hardware.md).
 *
 * Clock: HSE 25 MHz -> PLL: /25 *192 /2 = 96 MHz core, /4 = 48 MHz USB. SysTick: 1 kHz.
 * Samples: the ADC's data-ready interrupt pushes rows into a ring with their index; when the
 * ring is full the row is lost but the index still advances, so the host counts the loss.
 */
#include <stddef.h>

#include "ads131m04.h"
#include "board.h"
#include "stm32f4.h"
#include "usb_cdc.h"

#define FS_V 1.2                      /* ADC full scale at gain 1 */
#define FULL_SCALE 8388608.0
/* nominal sensors: modal hammer 2.25 mV/N (PCB 086C03), accelerometers 10 mV/g = 1.02 mV/(m/s^2);
 * a bench configuration replaces them with the calibration sheet's values */
#define HAMMER_V_PER_N 2.25e-3
#define ACC_V_PER_MS2 1.02e-3

static const uint32_t OSR[] = {128, 256, 512, 1024, 2048, 4096, 8192, 16256};

#define FORCE_CH(name)                                                                        \
    {name, "force", "N", FS_V / FULL_SCALE / HAMMER_V_PER_N, 0.0, FS_V / HAMMER_V_PER_N, 24, \
     1000.0 * HAMMER_V_PER_N, "mV/N"}
#define ACC_CH(name)                                                                                   \
    {name, "acceleration", "m/s^2", FS_V / FULL_SCALE / ACC_V_PER_MS2, 0.0, FS_V / ACC_V_PER_MS2, 24, \
     1000.0 * ACC_V_PER_MS2, "mV/(m/s^2)"}

static const board_channel CHANNELS[] = {FORCE_CH("force"), ACC_CH("acc"), ACC_CH("acc2"), ACC_CH("acc3")};

static char serial[25];

static const board_info INFO = {
    .model = "EDDI-DAQ-F411 (Black Pill + ADS131M04)",
    .serial = serial,
    .firmware = "1.0.0",
    .n_channels = 4,
    .channels = CHANNELS,
    .osr = OSR,
    .n_osr = sizeof OSR / sizeof OSR[0],
    .modulator_hz = 4.0e6,
    .default_osr_index = 3,
    .has_hammer = 0,
};

#define RING 1024u
static int32_t ring[RING][ADS_CHANNELS];
static volatile uint32_t ring_head, ring_tail;
static uint64_t ring_index[RING];       /* each row's sample index */
static volatile uint64_t acquired;      /* rows the ADC delivered since configure (lost included) */
static volatile uint32_t millis;

const board_info *board_get_info(void)
{
    return &INFO;
}

void SysTick_Handler(void)
{
    millis++;
}

uint32_t board_millis(void)
{
    return millis;
}

static void clock_init(void)
{
    RCC_CR |= 1u << 16;                                  /* HSE on */
    while (!(RCC_CR & (1u << 17))) {
    }
    FLASH_ACR = (1u << 8) | (1u << 9) | (1u << 10) | 3u; /* prefetch, caches, 3 wait states */
    RCC_PLLCFGR = 25u | (192u << 6) | (0u << 16) | (1u << 22) | (4u << 24);
    RCC_CFGR = (4u << 10);                               /* APB1 /2 (48 MHz), APB2 /1 */
    RCC_CR |= 1u << 24;                                  /* PLL on */
    while (!(RCC_CR & (1u << 25))) {
    }
    RCC_CFGR = (RCC_CFGR & ~3u) | 2u;                    /* system clock: PLL */
    while ((RCC_CFGR & 0xCu) != 0x8u) {
    }
}

static void read_serial(void)
{
    static const char hex[] = "0123456789ABCDEF";
    const volatile uint32_t *uid = (const volatile uint32_t *)0x1FFF7A10u;
    for (unsigned w = 0; w < 3u; w++) {
        uint32_t v = uid[w];
        for (unsigned k = 0; k < 8u; k++)
            serial[8u * w + k] = hex[(v >> (28u - 4u * k)) & 0xFu];
    }
    serial[24] = 0;
}

void board_init(void)
{
    clock_init();
    read_serial();
    SYST_RVR = 96000000u / 1000u - 1u;
    SYST_CVR = 0;
    SYST_CSR = 7u;
    usb_cdc_init(serial);
    ads_init();
}

void board_poll(void)
{
    usb_cdc_poll();
}

void board_idle(void)
{
}

int board_rx(uint8_t *b)
{
    return usb_cdc_read(b);
}

size_t board_tx(const uint8_t *p, size_t n)
{
    return usb_cdc_write(p, n);
}

void ads_on_sample(const int32_t *counts)
{
    if (ring_head - ring_tail < RING) {
        for (unsigned c = 0; c < ADS_CHANNELS; c++)
            ring[ring_head % RING][c] = counts[c];
        ring_index[ring_head % RING] = acquired;
        ring_head++;
    }
    acquired++;                        /* a lost row still advances the counter */
}

void source_configure(unsigned osr_index)
{
    ads_configure(osr_index);
    ring_head = ring_tail = 0;
    acquired = 0;
}

void source_start(uint64_t first_sample)
{
    acquired = first_sample;
    ring_head = ring_tail = 0;
    ads_start();
}

void source_stop(void)
{
    ads_stop();
}

int source_read(int32_t *row, uint64_t *index)
{
    if (ring_head == ring_tail)
        return 0;
    uint32_t t = ring_tail;                /* only the interrupt moves ring_head */
    *index = ring_index[t % RING];
    for (unsigned c = 0; c < ADS_CHANNELS; c++)
        row[c] = ring[t % RING][c];
    ring_tail = t + 1u;
    return 1;
}

uint64_t source_position(void)
{
    __asm volatile("cpsid i" ::: "memory");   /* a 64-bit read the interrupt may tear */
    uint64_t a = acquired;
    __asm volatile("cpsie i" ::: "memory");
    return a;
}

uint64_t source_impact(double peak_force_n, int double_hit, const char **err)
{
    (void)peak_force_n;
    (void)double_hit;
    *err = "this device has no hammer";
    return UINT64_MAX;
}

const char *source_scenario_json(void)
{
    return NULL;
}
