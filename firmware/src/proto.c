/* EDDI DAQ wire protocol v1: CRC-32, COBS and framing (see proto.h, docs/protocol.md). */
#include "proto.h"

#include <string.h>

static uint32_t crc_table[256];
static int crc_ready;

static void crc_init(void)
{
    for (uint32_t i = 0; i < 256u; i++) {
        uint32_t c = i;
        for (int k = 0; k < 8; k++)
            c = (c & 1u) ? (c >> 1) ^ 0xEDB88320u : c >> 1;
        crc_table[i] = c;
    }
    crc_ready = 1;
}

uint32_t proto_crc32(uint32_t crc, const uint8_t *p, size_t n)
{
    if (!crc_ready)
        crc_init();
    crc = ~crc;
    for (size_t i = 0; i < n; i++)
        crc = crc_table[(crc ^ p[i]) & 0xFFu] ^ (crc >> 8);
    return ~crc;
}

void proto_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

void proto_put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

void proto_put_u64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

uint32_t proto_get_u32(const uint8_t *p)
{
    return (uint32_t)p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}

uint64_t proto_get_u64(const uint8_t *p)
{
    return (uint64_t)proto_get_u32(p) | ((uint64_t)proto_get_u32(p + 4) << 32);
}

double proto_get_f64(const uint8_t *p)
{
    uint64_t u = proto_get_u64(p);
    double d;
    memcpy(&d, &u, sizeof d);
    return d;
}

void proto_header(uint8_t *raw, uint8_t type, uint32_t seq)
{
    raw[0] = PROTO_VERSION;
    raw[1] = type;
    proto_put_u32(raw + 2, seq);
}

void proto_put_sample(uint8_t *p, int32_t v, unsigned width)
{
    uint32_t u = (uint32_t)v;
    p[0] = (uint8_t)u;
    p[1] = (uint8_t)(u >> 8);
    if (width == 3u)
        p[2] = (uint8_t)(u >> 16);
}

size_t proto_frame_bound(size_t raw_len)
{
    return raw_len + raw_len / 254u + 3u;
}

size_t proto_frame(uint8_t *raw, size_t raw_len, uint8_t *out, size_t out_cap)
{
    proto_put_u32(raw + raw_len, proto_crc32(0, raw, raw_len));
    raw_len += 4u;
    if (out_cap < proto_frame_bound(raw_len))
        return 0;
    size_t o = 0;
    out[o++] = 0;
    size_t code_pos = o++;
    uint8_t code = 1;
    for (size_t i = 0; i < raw_len; i++) {
        uint8_t b = raw[i];
        if (b == 0) {
            out[code_pos] = code;
            code_pos = o++;
            code = 1;
        } else {
            out[o++] = b;
            if (++code == 0xFFu) {
                out[code_pos] = code;
                code_pos = o++;
                code = 1;
            }
        }
    }
    out[code_pos] = code;
    out[o++] = 0;
    return o;
}

void proto_rx_init(proto_rx *rx)
{
    memset(rx, 0, sizeof *rx);
}

static void rx_reset(proto_rx *rx)
{
    rx->len = 0;
    rx->code = 0;
    rx->left = 0;
    rx->overflow = 0;
    rx->bad = 0;
}

static int rx_end(proto_rx *rx, proto_msg *msg)
{
    int empty = rx->len == 0 && rx->code == 0 && !rx->overflow;
    int ok = 0;
    if (empty) {
        /* two delimiters in a row: nothing */
    } else if (rx->overflow || rx->bad || rx->left != 0 || rx->len < PROTO_MIN_FRAME) {
        rx->framing_errors++;
    } else {
        /* the last code block adds no implied zero: drop the one appended after it */
        size_t n = rx->len;
        uint32_t got = proto_get_u32(rx->buf + n - 4u);
        if (proto_crc32(0, rx->buf, n - 4u) != got) {
            rx->crc_errors++;
        } else {
            msg->version = rx->buf[0];
            msg->type = rx->buf[1];
            msg->seq = proto_get_u32(rx->buf + 2);
            msg->body = rx->buf + PROTO_HEADER_BYTES;
            msg->body_len = n - PROTO_MIN_FRAME;
            ok = 1;
        }
    }
    rx_reset(rx);
    return ok;
}

int proto_rx_byte(proto_rx *rx, uint8_t b, proto_msg *msg)
{
    if (b == 0)
        return rx_end(rx, msg);
    if (rx->overflow)
        return 0;
    if (rx->left == 0) {
        /* a code byte: the previous block (if any, and shorter than 254) implied a zero */
        if (rx->code != 0 && rx->code < 0xFFu) {
            if (rx->len >= sizeof rx->buf) {
                rx->overflow = 1;
                return 0;
            }
            rx->buf[rx->len++] = 0;
        }
        rx->code = b;
        rx->left = (unsigned)b - 1u;
        return 0;
    }
    if (rx->len >= sizeof rx->buf) {
        rx->overflow = 1;
        return 0;
    }
    rx->buf[rx->len++] = b;
    rx->left--;
    return 0;
}
