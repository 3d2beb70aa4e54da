/* Host-built checker of the firmware's codec (proto.c, json.c), driven line by line on stdin by
 * tests/firmware/test_firmware_codec.py with the vectors of tests/vectors/protocol_v1.json:
 *
 *   data SEQ FIRST WIDTH MASK N NCH c00 c01 ...     -> hex of the encoded DATA frame
 *   reply SEQ CSEQ CTYPE STATUS i KEY INT           -> hex of a REPLY frame {"KEY":INT}
 *   reply SEQ CSEQ CTYPE STATUS s KEY TEXT...       -> hex of a REPLY frame {"KEY":"TEXT..."}
 *   decode HEX                                      -> one line per good frame, then the counts
 *   crc TEXT                                        -> CRC-32 of TEXT
 *   f64 VALUE                                       -> the JSON text of a double
 *   synth RATE N MASS C1 K1 K3 NOISE                -> N lines "force acc" of the on-chip source
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "json.h"
#include "proto.h"
#include "synth.h"

static uint8_t raw[70000];
static uint8_t out[80000];

static void print_hex(const uint8_t *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        printf("%02x", p[i]);
    printf("\n");
}

static void do_data(char *args)
{
    unsigned long long seq = strtoull(strtok(args, " "), NULL, 10);
    unsigned long long first = strtoull(strtok(NULL, " "), NULL, 10);
    unsigned width = (unsigned)strtoul(strtok(NULL, " "), NULL, 10);
    unsigned long mask = strtoul(strtok(NULL, " "), NULL, 10);
    unsigned n = (unsigned)strtoul(strtok(NULL, " "), NULL, 10);
    unsigned nch = (unsigned)strtoul(strtok(NULL, " "), NULL, 10);
    proto_header(raw, PT_DATA, (uint32_t)seq);
    proto_put_u64(raw + 6, first);
    proto_put_u16(raw + 14, (uint16_t)n);
    raw[16] = (uint8_t)nch;
    raw[17] = (uint8_t)width;
    proto_put_u32(raw + 18, (uint32_t)mask);
    size_t len = PROTO_HEADER_BYTES + PROTO_DATA_HEADER_BYTES;
    for (unsigned i = 0; i < n * nch; i++) {
        long v = strtol(strtok(NULL, " "), NULL, 10);
        proto_put_sample(raw + len, (int32_t)v, width);
        len += width;
    }
    print_hex(out, proto_frame(raw, len, out, sizeof out));
}

static void do_reply(char *args)
{
    char *rest;
    unsigned long seq = strtoul(strtok_r(args, " ", &rest), NULL, 10);
    unsigned long cseq = strtoul(strtok_r(NULL, " ", &rest), NULL, 10);
    unsigned ctype = (unsigned)strtoul(strtok_r(NULL, " ", &rest), NULL, 10);
    unsigned status = (unsigned)strtoul(strtok_r(NULL, " ", &rest), NULL, 10);
    char *kind = strtok_r(NULL, " ", &rest);
    char *key = strtok_r(NULL, " ", &rest);
    char text[4096];
    json_w w;
    json_init(&w, text, sizeof text);
    json_begin(&w, '{');
    json_key(&w, key);
    if (kind[0] == 'i')
        json_i64(&w, strtoll(rest, NULL, 10));
    else
        json_str(&w, rest);
    json_end(&w, '}');
    proto_header(raw, PT_REPLY, (uint32_t)seq);
    proto_put_u32(raw + 6, (uint32_t)cseq);
    raw[10] = (uint8_t)ctype;
    raw[11] = (uint8_t)status;
    memcpy(raw + 12, text, w.len);
    print_hex(out, proto_frame(raw, 12 + w.len, out, sizeof out));
}

static void print_frame(const proto_msg *m)
{
    printf("frame %u %u %lu", m->version, m->type, (unsigned long)m->seq);
    const uint8_t *b = m->body;
    if (m->type == PT_CONFIGURE && m->body_len == 14)
        printf(" %.17g %lu %u", proto_get_f64(b), (unsigned long)proto_get_u32(b + 8), b[12] | (b[13] << 8));
    else if (m->type == PT_IMPACT && m->body_len == 9)
        printf(" %.17g %u", proto_get_f64(b), b[8]);
    else if (m->type == PT_DATA && m->body_len >= 16) {
        unsigned n = b[8] | (b[9] << 8), nch = b[10], width = b[11];
        printf(" %llu %u %u %u %lu", (unsigned long long)proto_get_u64(b), n, nch, width,
               (unsigned long)proto_get_u32(b + 12));
        const uint8_t *p = b + 16;
        for (unsigned i = 0; i < n * nch && (size_t)(p - b) + width <= m->body_len; i++, p += width) {
            long v = width == 3 ? (long)(p[0] | (p[1] << 8) | (p[2] << 16)) : (long)(p[0] | (p[1] << 8));
            long top = width == 3 ? 0x800000L : 0x8000L;
            printf(" %ld", (v ^ top) - top);
        }
    } else if (m->type == PT_REPLY && m->body_len >= 6) {
        printf(" %lu %u %u %.*s", (unsigned long)proto_get_u32(b), b[4], b[5], (int)(m->body_len - 6),
               (const char *)b + 6);
    }
    printf("\n");
}

/* The receiver of the firmware, built here with PROTO_RX_BYTES large enough for DATA frames. */
static void do_decode(const char *hex)
{
    static proto_rx rx;
    proto_rx_init(&rx);
    size_t n = strlen(hex) / 2;
    for (size_t i = 0; i < n; i++) {
        unsigned v;
        sscanf(hex + 2 * i, "%2x", &v);
        proto_msg m;
        if (proto_rx_byte(&rx, (uint8_t)v, &m))
            print_frame(&m);
    }
    printf("stats %lu %lu\n", (unsigned long)rx.crc_errors, (unsigned long)rx.framing_errors);
}

static void do_synth(const char *args)
{
    double rate, mass, c1, k1, k3, noise;
    unsigned long n;
    if (sscanf(args, "%lf %lu %lf %lf %lf %lf %lf", &rate, &n, &mass, &c1, &k1, &k3, &noise) != 7)
        return;
    synth_params p = SYNTH_DEFAULT;
    p.mass_kg = (float)mass;
    p.c1 = (float)c1;
    p.k1 = (float)k1;
    p.k3 = (float)k3;
    p.force_noise_n = (float)noise;
    p.acc_noise_ms2 = (float)noise;
    synth s;
    synth_init(&s, &p, rate, 1u);
    for (unsigned long i = 0; i < n; i++) {
        float f, a;
        synth_next(&s, &f, &a);
        printf("%.9g %.9g\n", (double)f, (double)a);
    }
}

int main(void)
{
    static char line[200000];
    while (fgets(line, sizeof line, stdin)) {
        line[strcspn(line, "\n")] = 0;
        char *sp = strchr(line, ' ');
        if (!sp)
            continue;
        *sp = 0;
        char *args = sp + 1;
        if (!strcmp(line, "data"))
            do_data(args);
        else if (!strcmp(line, "reply"))
            do_reply(args);
        else if (!strcmp(line, "decode"))
            do_decode(args);
        else if (!strcmp(line, "synth"))
            do_synth(args);
        else if (!strcmp(line, "crc"))
            printf("%08lx\n", (unsigned long)proto_crc32(0, (const uint8_t *)args, strlen(args)));
        else if (!strcmp(line, "f64")) {
            char text[64];
            json_w w;
            json_init(&w, text, sizeof text);
            json_f64(&w, strtod(args, NULL));
            printf("%.*s\n", (int)w.len, text);
        } else
            printf("unknown %s\n", line);
        fflush(stdout);
    }
    return 0;
}
