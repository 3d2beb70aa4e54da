/* On-chip signal source of the emulated DAQ: a Duffing oscillator hit by a modal hammer.
 *
 *     m x'' + c v + k1 x + k3 x^3 = F(t)
 *
 * F(t) is a half-sine pulse (a hammer blow), repeated every impact_period_s at peak forces
 * from a fixed cycle (and on demand, IMPACT command). One RK4 step of 1/rate per sample
 * (single precision, the Cortex-M4 FPU), plus white noise from a xorshift32 generator on both
 * channels. Channel 0: force [N] (the blow plus noise), channel 1: acceleration [m/s^2].
 */
#ifndef EDDI_SYNTH_H
#define EDDI_SYNTH_H

#include <stdint.h>

typedef struct {
    float mass_kg, c1, k1, k3;         /* N s/m, N/m, N/m^3 */
    float pulse_s;                     /* hammer contact time */
    float impact_period_s, first_impact_s;
    float force_noise_n, acc_noise_ms2;  /* rms */
    float double_hit_ratio, double_hit_delay_s;
} synth_params;

typedef struct {
    synth_params p;
    float h;                 /* 1 / rate */
    float x, v;
    uint64_t k;              /* sample index */
    uint64_t next_auto;      /* sample of the next automatic blow */
    uint64_t period;         /* samples between automatic blows */
    uint64_t blow_at;        /* start of the current blow (UINT64_MAX: none) */
    float blow_peak;
    int blow_double;
    unsigned cycle;          /* position in the peak cycle */
    uint32_t rng;
} synth;

extern const synth_params SYNTH_DEFAULT;
extern const float SYNTH_PEAKS_N[];
extern const unsigned SYNTH_N_PEAKS;

void synth_init(synth *s, const synth_params *p, double rate_hz, uint32_t seed);
/* Sample k: force [N] and acceleration [m/s^2] (with noise), then advance one step. */
void synth_next(synth *s, float *force, float *acc);
/* A blow of peak_n newtons starting `delay` samples from now; returns its first sample. */
uint64_t synth_impact(synth *s, float peak_n, int double_hit, uint64_t delay);

#endif
