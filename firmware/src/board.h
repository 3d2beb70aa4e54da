/* What the protocol core (daq.c) needs from a board: a byte link, a millisecond clock,
 * a sample source and the channel descriptions.
 *
 * Two boards implement it: board_qemu.c (netduinoplus2 in QEMU: USART1, on-chip synthetic
 * Duffing oscillator) and board_hw.c (STM32F411 "Black Pill": USB CDC, ADS131M04 over SPI).
 */
#ifndef EDDI_BOARD_H
#define EDDI_BOARD_H

#include <stddef.h>
#include <stdint.h>

#define BOARD_MAX_CHANNELS 4

typedef struct {
    const char *name, *quantity, *unit;
    double scale;          /* SI units per count */
    double offset;         /* SI value at count 0 */
    double range_si;       /* full scale magnitude, SI */
    int adc_bits;
    double sensitivity;    /* as on the sensor's calibration sheet */
    const char *sensitivity_unit;
} board_channel;

typedef struct {
    const char *model, *serial, *firmware;
    unsigned n_channels;
    const board_channel *channels;
    const uint32_t *osr;            /* oversampling ratios the ADC supports, ascending */
    unsigned n_osr;
    double modulator_hz;            /* sample rate = modulator_hz / osr */
    unsigned default_osr_index;
    int has_hammer;                 /* answers IMPACT (the synthetic source only) */
} board_info;

const board_info *board_get_info(void);
void board_init(void);
void board_poll(void);                           /* housekeeping (USB stack) */
uint32_t board_millis(void);                     /* since power-on, [ms] */
void board_idle(void);                           /* nothing to do: sleep until an interrupt */

/* Link to the host. */
int board_rx(uint8_t *b);                        /* 1 when a byte was read */
size_t board_tx(const uint8_t *p, size_t n);     /* bytes taken now (may be 0) */

/* Sample source. */
void source_configure(unsigned osr_index);       /* stopped; resets the sample counter */
void source_start(uint64_t first_sample);
void source_stop(void);
/* Next acquired row (counts per channel, all channels) and its sample index; 0 if none yet.
 * Indices increase; a jump means the source lost samples (counted by the host). */
int source_read(int32_t *row, uint64_t *index);
/* Samples the source has acquired (next index), for STATUS and STOP. */
uint64_t source_position(void);
/* Schedule a hammer blow (synthetic source). Returns the sample index it lands at, or
 * UINT64_MAX when refused (err says why). */
uint64_t source_impact(double peak_force_n, int double_hit, const char **err);
/* The source's description as JSON text (object) or NULL. */
const char *source_scenario_json(void);

#endif
