/* EDDI DAQ wire protocol v1 (docs/protocol.md): CRC-32, COBS, frame codec.
 *
 * Pure C99, no hardware: built for the STM32 targets and for the host unit test
 * (host/codec_check.c), which checks it against tests/vectors/protocol_v1.json.
 */
#ifndef EDDI_PROTO_H
#define EDDI_PROTO_H

#include <stddef.h>
#include <stdint.h>

#define PROTO_VERSION 1u
#define PROTO_HEADER_BYTES 6u          /* version u8, type u8, seq u32 */
#define PROTO_DATA_HEADER_BYTES 16u    /* first u64, n u16, nch u8, width u8, mask u32 */
#define PROTO_MIN_FRAME 10u            /* header + crc */
/* Largest decoded frame the receiver holds: commands are at most 25 bytes; the host checker
 * builds with a large value to decode the DATA vectors with the same code. */
#ifndef PROTO_RX_BYTES
#define PROTO_RX_BYTES 68u
#endif

enum proto_type {
    PT_DATA = 0x01, PT_REPLY = 0x02,
    PT_IDENTIFY = 0x41, PT_CONFIGURE = 0x42, PT_START = 0x43,
    PT_STOP = 0x44, PT_STATUS = 0x45, PT_IMPACT = 0x46
};

enum proto_status {
    PS_OK = 0, PS_BAD_COMMAND = 1, PS_BAD_VALUE = 2, PS_BAD_STATE = 3, PS_UNSUPPORTED = 4
};

/* CRC-32/ISO-HDLC (zlib), incremental: crc = proto_crc32(crc, p, n) starting from 0. */
uint32_t proto_crc32(uint32_t crc, const uint8_t *p, size_t n);

/* Little-endian stores / loads. */
void proto_put_u16(uint8_t *p, uint16_t v);
void proto_put_u32(uint8_t *p, uint32_t v);
void proto_put_u64(uint8_t *p, uint64_t v);
uint32_t proto_get_u32(const uint8_t *p);
uint64_t proto_get_u64(const uint8_t *p);
double proto_get_f64(const uint8_t *p);

/* Frame a raw payload (header | body, without crc): appends the CRC in place (raw needs 4
 * spare bytes) and writes 0x00 COBS(raw|crc) 0x00 to out. Returns bytes written, 0 if out
 * (capacity out_cap) is too small. */
size_t proto_frame(uint8_t *raw, size_t raw_len, uint8_t *out, size_t out_cap);

/* Bytes proto_frame writes at most for a raw payload of raw_len bytes (crc included). */
size_t proto_frame_bound(size_t raw_len);

/* Write the 6-byte header. */
void proto_header(uint8_t *raw, uint8_t type, uint32_t seq);

/* Pack one sample (two's complement, little-endian, width 2 or 3 bytes). */
void proto_put_sample(uint8_t *p, int32_t v, unsigned width);

/* Byte-at-a-time receiver: COBS decode, length and CRC checks. */
typedef struct {
    uint8_t buf[PROTO_RX_BYTES];
    size_t len;          /* decoded bytes so far */
    unsigned code;       /* COBS code in progress (0: expecting a code byte) */
    unsigned left;       /* data bytes left in this code block */
    int overflow;        /* segment longer than buf */
    int bad;             /* invalid COBS (zero inside a block is impossible; kept for symmetry) */
    uint32_t crc_errors, framing_errors;
} proto_rx;

typedef struct {
    uint8_t version, type;
    uint32_t seq;
    const uint8_t *body;
    size_t body_len;
} proto_msg;

void proto_rx_init(proto_rx *rx);

/* Feed one byte. Returns 1 when a frame with a good CRC completed (msg filled, valid until
 * the next call), 0 otherwise. Bad frames are counted in crc_errors / framing_errors. */
int proto_rx_byte(proto_rx *rx, uint8_t b, proto_msg *msg);

#endif
