/* Synthetic Duffing oscillator and hammer (see synth.h). */
#include "synth.h"

#include <math.h>

const synth_params SYNTH_DEFAULT = {
    .mass_kg = 0.5f, .c1 = 0.8f, .k1 = 2000.0f, .k3 = 5.0e6f,
    .pulse_s = 2.0e-3f,
    .impact_period_s = 5.0f, .first_impact_s = 1.5f,
    .force_noise_n = 0.05f, .acc_noise_ms2 = 0.05f,
    .double_hit_ratio = 0.3f, .double_hit_delay_s = 4.0e-3f,
};

const float SYNTH_PEAKS_N[] = {400.0f, 250.0f, 550.0f, 320.0f, 480.0f};
const unsigned SYNTH_N_PEAKS = sizeof SYNTH_PEAKS_N / sizeof SYNTH_PEAKS_N[0];

static const float PI_F = 3.14159265358979f;

void synth_init(synth *s, const synth_params *p, double rate_hz, uint32_t seed)
{
    s->p = *p;
    s->h = (float)(1.0 / rate_hz);
    s->x = 0.0f;
    s->v = 0.0f;
    s->k = 0;
    s->period = (uint64_t)(p->impact_period_s * rate_hz + 0.5);
    s->next_auto = (uint64_t)(p->first_impact_s * rate_hz + 0.5);
    s->blow_at = UINT64_MAX;
    s->blow_peak = 0.0f;
    s->blow_double = 0;
    s->cycle = 0;
    s->rng = seed ? seed : 0x2545F491u;
}

/* Hammer force at time tau [s] after the start of the blow. */
static float blow_force(const synth *s, float tau)
{
    float f = 0.0f;
    float w = s->p.pulse_s;
    if (tau >= 0.0f && tau <= w)
        f += s->blow_peak * sinf(PI_F * tau / w);
    if (s->blow_double) {
        float t2 = tau - s->p.double_hit_delay_s;
        if (t2 >= 0.0f && t2 <= w)
            f += s->p.double_hit_ratio * s->blow_peak * sinf(PI_F * t2 / w);
    }
    return f;
}

static float force_at(const synth *s, float dt)
{
    if (s->blow_at == UINT64_MAX || s->k < s->blow_at)
        return 0.0f;
    float tau = (float)(s->k - s->blow_at) * s->h + dt;
    return blow_force(s, tau);
}

static float accel(const synth *s, float x, float v, float f)
{
    return (f - s->p.c1 * v - s->p.k1 * x - s->p.k3 * x * x * x) / s->p.mass_kg;
}

/* Standard normal (approximately): the sum of 4 uniforms, scaled. */
static float gauss(synth *s)
{
    float sum = 0.0f;
    for (int i = 0; i < 4; i++) {
        uint32_t r = s->rng;
        r ^= r << 13;
        r ^= r >> 17;
        r ^= r << 5;
        s->rng = r;
        sum += (float)(r >> 8) * (1.0f / 16777216.0f);
    }
    return (sum - 2.0f) * 1.7320508f;
}

uint64_t synth_impact(synth *s, float peak_n, int double_hit, uint64_t delay)
{
    s->blow_at = s->k + delay;
    s->blow_peak = peak_n;
    s->blow_double = double_hit;
    return s->blow_at;
}

void synth_next(synth *s, float *force, float *acc)
{
    if (s->k == s->next_auto) {
        synth_impact(s, SYNTH_PEAKS_N[s->cycle % SYNTH_N_PEAKS], 0, 0);
        s->cycle++;
        s->next_auto += s->period;
    }
    float h = s->h;
    float f0 = force_at(s, 0.0f);
    float fm = force_at(s, 0.5f * h);
    float f1 = force_at(s, h);
    float x = s->x, v = s->v;
    *force = f0 + s->p.force_noise_n * gauss(s);
    *acc = accel(s, x, v, f0) + s->p.acc_noise_ms2 * gauss(s);
    /* RK4 over [t_k, t_k + h] */
    float k1x = v, k1v = accel(s, x, v, f0);
    float k2x = v + 0.5f * h * k1v, k2v = accel(s, x + 0.5f * h * k1x, v + 0.5f * h * k1v, fm);
    float k3x = v + 0.5f * h * k2v, k3v = accel(s, x + 0.5f * h * k2x, v + 0.5f * h * k2v, fm);
    float k4x = v + h * k3v, k4v = accel(s, x + h * k3x, v + h * k3v, f1);
    s->x = x + h / 6.0f * (k1x + 2.0f * k2x + 2.0f * k3x + k4x);
    s->v = v + h / 6.0f * (k1v + 2.0f * k2v + 2.0f * k3v + k4v);
    s->k++;
}
