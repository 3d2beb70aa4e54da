/* TI ADS131M04: 4-channel, 24-bit, simultaneous-sampling delta-sigma ADC on SPI1. */
#ifndef EDDI_ADS131M04_H
#define EDDI_ADS131M04_H

#include <stdint.h>

#define ADS_CHANNELS 4u

void ads_init(void);
void ads_configure(unsigned osr_code);     /* 0..7: OSR 128..16256; stops the stream */
void ads_start(void);                      /* data-ready interrupts on */
void ads_stop(void);
/* Called by the data-ready interrupt with each conversion (four sign-extended counts). */
void ads_on_sample(const int32_t *counts);

#endif
