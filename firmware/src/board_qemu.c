/* Board: QEMU netduinoplus2 (STM32F405). Link: USART1 (QEMU -serial). Clock: TIM2's counter
 * (QEMU derives it from its virtual clock, i.e. host time: exact); SysTick at 1 kHz only wakes
 * the core from WFI (QEMU delivers its ticks late or not at all when the host is loaded, so
 * counting them would run slow: measured 9-72 % slow). Source: the synthetic Duffing
 * oscillator (synth.c), paced to TIM2, in place of the ADS131M04.
 *
 * QEMU's STM32 USART model writes each DR byte straight to the character device (no baud
 * rate), so the link is as fast as the emulated CPU and the host reader allow.
 */
#include <stddef.h>

#include "board.h"
#include "daq.h"
#include "json.h"
#include "stm32f4.h"
#include "synth.h"

#define CORE_HZ 168000000u
#define FORCE_RANGE_N 2000.0
#define ACC_RANGE_MS2 2000.0
#define FULL_SCALE 8388608.0          /* 2^23 counts */
#define ADC_FS_V 1.2                  /* ADS131M04 full scale at gain 1 */

static const uint32_t OSR[] = {128, 256, 512, 1024, 2048, 4096, 8192, 16256};

static const board_channel CHANNELS[] = {
    {"force", "force", "N", FORCE_RANGE_N / FULL_SCALE, 0.0, FORCE_RANGE_N, 24,
     1000.0 * ADC_FS_V / FORCE_RANGE_N, "mV/N"},
    {"acc", "acceleration", "m/s^2", ACC_RANGE_MS2 / FULL_SCALE, 0.0, ACC_RANGE_MS2, 24,
     1000.0 * ADC_FS_V / ACC_RANGE_MS2, "mV/(m/s^2)"},
};

static const board_info INFO = {
    .model = "EDDI-DAQ-F4 (QEMU netduinoplus2, synthetic Duffing source)",
    .serial = "QEMU-F405-0001",
    .firmware = "1.0.0",
    .n_channels = 2,
    .channels = CHANNELS,
    .osr = OSR,
    .n_osr = sizeof OSR / sizeof OSR[0],
    .modulator_hz = 4.0e6,
    .default_osr_index = 3,           /* 3906.25 Hz */
    .has_hammer = 1,
};

/* Parameters a host may poke before boot (QEMU: -device loader,addr=0x2001FF00,...): used
 * when the magic word is there and every value is in range, else SYNTH_DEFAULT. */
#define OVERRIDE_MAGIC 0xEDD15EEDu
typedef struct {
    uint32_t magic;
    float mass_kg, c1, k1, k3;
    uint32_t seed;
} synth_override;
__attribute__((section(".noinit"), used)) static volatile synth_override override;

static synth_params params;
static uint32_t seed = 0x12345678u;
static synth syn;
static int running;
static unsigned osr_index;
static uint64_t start_ticks;
static uint64_t start_sample;
static char scenario[640];

const board_info *board_get_info(void)
{
    return &INFO;
}

void SysTick_Handler(void)
{
}

/* TIM2 ticks at 100 kHz (QEMU's STM32 timer model runs at 1 GHz / (PSC + 1)), extended to
 * 64 bits; read at least every 11 hours (the main loop wakes every millisecond). */
#define TICK_HZ 100000u
static uint64_t ticks64;
static uint32_t last_cnt;

static uint64_t ticks(void)
{
    uint32_t c = TIM_CNT(TIM2_BASE);
    ticks64 += (uint32_t)(c - last_cnt);
    last_cnt = c;
    return ticks64;
}

uint32_t board_millis(void)
{
    return (uint32_t)(ticks() / (TICK_HZ / 1000u));
}

void board_init(void)
{
    RCC_APB2ENR |= 1u << 4;           /* USART1 */
    USART_BRR(USART1_BASE) = 0x2D9u;  /* 115200 Bd at 84 MHz; QEMU ignores it */
    USART_CR1(USART1_BASE) = USART_CR1_UE | USART_CR1_TE | USART_CR1_RE | USART_CR1_RXNEIE;
    NVIC_ISER(USART1_IRQn / 32u) = 1u << (USART1_IRQn % 32u);
    RCC_APB1ENR |= 1u << 0;           /* TIM2 */
    TIM_PSC(TIM2_BASE) = 1000000000u / TICK_HZ - 1u;
    TIM_ARR(TIM2_BASE) = 0xFFFFFFFFu;
    TIM_CR1(TIM2_BASE) = 1u;
    last_cnt = TIM_CNT(TIM2_BASE);
    SYST_RVR = CORE_HZ / 1000u - 1u;
    SYST_CVR = 0;
    SYST_CSR = 7u;                    /* core clock, interrupt, enable */
}

void board_poll(void)
{
}

/* Received bytes: the RXNE interrupt fills a ring, the main loop empties it. QEMU's USART
 * holds one byte at a time, so waiting in the interrupt keeps the link moving while the core
 * sleeps (WFI) instead of polling the status register, which would starve QEMU's I/O thread. */
#define RX_RING 256u
static volatile uint8_t rx_ring[RX_RING];
static volatile uint32_t rx_head, rx_tail;

void USART1_IRQHandler(void)
{
    while (USART_SR(USART1_BASE) & USART_SR_RXNE) {
        uint8_t b = (uint8_t)USART_DR(USART1_BASE);
        if (rx_head - rx_tail < RX_RING)
            rx_ring[rx_head++ % RX_RING] = b;
    }
}

int board_rx(uint8_t *b)
{
    if (rx_head == rx_tail)
        return 0;
    *b = rx_ring[rx_tail++ % RX_RING];
    return 1;
}

void board_idle(void)
{
    __asm volatile("wfi" ::: "memory");
}

size_t board_tx(const uint8_t *p, size_t n)
{
    size_t i = 0;
    for (; i < n; i++) {
        if (!(USART_SR(USART1_BASE) & USART_SR_TXE))
            break;
        USART_DR(USART1_BASE) = p[i];
    }
    return i;
}

static void load_params(void)
{
    params = SYNTH_DEFAULT;
    if (override.magic != OVERRIDE_MAGIC)
        return;
    float m = override.mass_kg, c = override.c1, k1 = override.k1, k3 = override.k3;
    if (m > 0.01f && m < 100.0f && c >= 0.0f && c < 1000.0f && k1 > 1.0f && k1 < 1.0e7f &&
        k3 >= 0.0f && k3 < 1.0e12f) {
        params.mass_kg = m;
        params.c1 = c;
        params.k1 = k1;
        params.k3 = k3;
        if (override.seed)
            seed = override.seed;
    }
}

static void build_scenario(void)
{
    const synth_params *p = &params;
    json_w w;
    json_init(&w, scenario, sizeof scenario);
    json_begin(&w, '{');
    json_key(&w, "source");
    json_str(&w, "eddi-firmware synth.c");
    json_key(&w, "equation");
    json_str(&w, "m x'' + c1 v + k1 x + k3 x^3 = F(t)");
    json_key(&w, "mass_kg");
    json_f64(&w, p->mass_kg);
    json_key(&w, "c1");
    json_f64(&w, p->c1);
    json_key(&w, "k1");
    json_f64(&w, p->k1);
    json_key(&w, "k3");
    json_f64(&w, p->k3);
    json_key(&w, "pulse_s");
    json_f64(&w, p->pulse_s);
    json_key(&w, "impact_period_s");
    json_f64(&w, p->impact_period_s);
    json_key(&w, "first_impact_s");
    json_f64(&w, p->first_impact_s);
    json_key(&w, "force_noise_n");
    json_f64(&w, p->force_noise_n);
    json_key(&w, "acc_noise_ms2");
    json_f64(&w, p->acc_noise_ms2);
    json_key(&w, "seed");
    json_u64(&w, seed);
    json_key(&w, "integrator");
    json_str(&w, "RK4, one step per sample, float32");
    json_key(&w, "impacts");
    json_begin(&w, '[');
    for (unsigned i = 0; i < SYNTH_N_PEAKS; i++)
        json_f64(&w, SYNTH_PEAKS_N[i]);
    json_end(&w, ']');
    json_end(&w, '}');
    scenario[w.len] = 0;
}

const char *source_scenario_json(void)
{
    return scenario;
}

static double rate(void)
{
    return INFO.modulator_hz / (double)OSR[osr_index];
}

void source_configure(unsigned index)
{
    osr_index = index;
    running = 0;
    if (!scenario[0]) {
        load_params();
        build_scenario();
    }
    synth_init(&syn, &params, rate(), seed);
}

void source_start(uint64_t first_sample)
{
    (void)first_sample;               /* the synth's own counter is the device counter */
    start_ticks = ticks();
    start_sample = syn.k;
    running = 1;
}

void source_stop(void)
{
    running = 0;
}

static uint64_t due(void)
{
    /* rate = 4 MHz / OSR = (40 / OSR) samples per tick */
    return start_sample + (ticks() - start_ticks) * 40u / OSR[osr_index];
}

int source_read(int32_t *row, uint64_t *index)
{
    if (!running || syn.k >= due())
        return 0;
    float f, a;
    *index = syn.k;
    synth_next(&syn, &f, &a);
    double cf = (double)f / CHANNELS[0].scale, ca = (double)a / CHANNELS[1].scale;
    const double lim = FULL_SCALE - 1.0;
    cf = cf > lim ? lim : (cf < -FULL_SCALE ? -FULL_SCALE : cf);
    ca = ca > lim ? lim : (ca < -FULL_SCALE ? -FULL_SCALE : ca);
    row[0] = (int32_t)(cf < 0 ? cf - 0.5 : cf + 0.5);
    row[1] = (int32_t)(ca < 0 ? ca - 0.5 : ca + 0.5);
    return 1;
}

uint64_t source_position(void)
{
    return syn.k;
}

uint64_t source_impact(double peak_force_n, int double_hit, const char **err)
{
    if (!(peak_force_n > 0.0) || peak_force_n > 0.9 * FORCE_RANGE_N) {
        *err = "impact peak force must be in (0, 1800] N";
        return UINT64_MAX;
    }
    uint64_t now = running ? due() : syn.k;
    uint64_t delay = now > syn.k ? now - syn.k : 0u;
    return synth_impact(&syn, (float)peak_force_n, double_hit, delay);
}
