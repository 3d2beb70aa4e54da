/* The protocol core (see daq.h). Board independent: the same file runs on the STM32F411 with
 * the ADS131M04 and in QEMU with the synthetic source.
 *
 * Output path: rows from the source are packed into a DATA payload; a full block (or a gap in
 * the source's sample index, or STOP) is framed into the output FIFO. A frame that does not fit
 * is dropped whole (counted in overrun_frames; seq and the sample counter still advance, so
 * the host counts the loss exactly). Replies never drop: they wait for FIFO space.
 */
#include "daq.h"

#include <string.h>

#include "board.h"
#include "json.h"
#include "proto.h"

#define DATA_OFF (PROTO_HEADER_BYTES + PROTO_DATA_HEADER_BYTES)
#define RAW_DATA_BYTES (DATA_OFF + DAQ_MAX_BLOCK * BOARD_MAX_CHANNELS * 3u + 4u)
#define RAW_REPLY_BYTES 2048u
#define JSON_MAX (RAW_REPLY_BYTES - PROTO_HEADER_BYTES - 6u - 4u)

static struct {
    const board_info *info;
    int streaming;
    uint32_t seq, frames_sent, overrun_frames;
    uint32_t mask;
    unsigned nch, width;
    unsigned block_size;
    unsigned osr_index;
    uint64_t block_first;
    unsigned block_n;
    uint64_t next_sample;         /* counter after the last row taken from the source */
    uint32_t started_ms;
} d;

static uint8_t raw_data[RAW_DATA_BYTES];
static uint8_t raw_reply[RAW_REPLY_BYTES];
static uint8_t enc[RAW_DATA_BYTES + RAW_DATA_BYTES / 254u + 8u];
static uint8_t fifo[DAQ_FIFO_BYTES];
static uint32_t fifo_head, fifo_tail;     /* head: write, tail: read; free-running */
static proto_rx rx;

/* ------------------------------------------------------------------ output FIFO */

static uint32_t fifo_used(void)
{
    return fifo_head - fifo_tail;
}

static void fifo_push(const uint8_t *p, uint32_t n)
{
    for (uint32_t i = 0; i < n; i++)
        fifo[(fifo_head + i) % DAQ_FIFO_BYTES] = p[i];
    fifo_head += n;
}

static void fifo_drain(void)
{
    while (fifo_used()) {
        uint32_t start = fifo_tail % DAQ_FIFO_BYTES;
        uint32_t n = fifo_used();
        if (n > DAQ_FIFO_BYTES - start)
            n = DAQ_FIFO_BYTES - start;
        size_t took = board_tx(fifo + start, n);
        fifo_tail += (uint32_t)took;
        if (took < n)
            return;
    }
}

/* ------------------------------------------------------------------ DATA frames */

static void count_channels(void)
{
    d.nch = 0;
    for (unsigned i = 0; i < d.info->n_channels; i++)
        if (d.mask >> i & 1u)
            d.nch++;
    d.width = 2;
    for (unsigned i = 0; i < d.info->n_channels; i++)
        if ((d.mask >> i & 1u) && d.info->channels[i].adc_bits > 16)
            d.width = 3;
}

static void emit_block(void)
{
    if (!d.block_n)
        return;
    uint8_t *p = raw_data;
    proto_header(p, PT_DATA, d.seq);
    proto_put_u64(p + 6, d.block_first);
    proto_put_u16(p + 14, (uint16_t)d.block_n);
    p[16] = (uint8_t)d.nch;
    p[17] = (uint8_t)d.width;
    proto_put_u32(p + 18, d.mask);
    size_t raw_len = DATA_OFF + (size_t)d.block_n * d.nch * d.width;
    size_t n = proto_frame(raw_data, raw_len, enc, sizeof enc);
    d.seq++;
    d.block_n = 0;
    if (n && n <= DAQ_FIFO_BYTES - fifo_used()) {
        fifo_push(enc, (uint32_t)n);
        d.frames_sent++;
    } else {
        d.overrun_frames++;
    }
}

static void add_row(const int32_t *row, uint64_t index)
{
    if (d.block_n && index != d.block_first + d.block_n)
        emit_block();                         /* the source lost samples: a new frame */
    if (!d.block_n)
        d.block_first = index;
    uint8_t *p = raw_data + DATA_OFF + (size_t)d.block_n * d.nch * d.width;
    for (unsigned i = 0; i < d.info->n_channels; i++) {
        if (d.mask >> i & 1u) {
            proto_put_sample(p, row[i], d.width);
            p += d.width;
        }
    }
    d.block_n++;
    d.next_sample = index + 1u;
    if (d.block_n >= d.block_size)
        emit_block();
}

/* Rows taken from the source; 0 when it had none ready. */
static unsigned take_rows(void)
{
    int32_t row[BOARD_MAX_CHANNELS];
    uint64_t index;
    unsigned n = 0;
    while (n < 4u * DAQ_MAX_BLOCK && source_read(row, &index)) {  /* keep serving commands */
        add_row(row, index);
        n++;
    }
    return n;
}

/* ------------------------------------------------------------------ replies */

static double rate_hz(unsigned osr_index)
{
    return d.info->modulator_hz / (double)d.info->osr[osr_index];
}

static void send_reply(const proto_msg *cmd, uint8_t status, const json_w *w)
{
    static const char too_long[] = "{\"error\":\"reply does not fit the firmware's buffer\"}";
    json_w fallback;
    if (w->overflow) {   /* never send truncated JSON */
        fallback.buf = (char *)(uintptr_t)too_long;
        fallback.len = sizeof too_long - 1u;
        w = &fallback;
        status = PS_BAD_VALUE;
    }
    uint8_t *p = raw_reply;
    proto_header(p, PT_REPLY, d.seq++);
    proto_put_u32(p + 6, cmd->seq);
    p[10] = cmd->type;
    p[11] = status;
    memcpy(p + 12, w->buf, w->len);
    size_t n = proto_frame(raw_reply, 12u + w->len, enc, sizeof enc);
    while (DAQ_FIFO_BYTES - fifo_used() < n) {   /* a reply is never dropped */
        board_poll();
        fifo_drain();
    }
    fifo_push(enc, (uint32_t)n);
    d.frames_sent++;
}

static char json_buf[JSON_MAX];

static void reply_error(const proto_msg *cmd, uint8_t status, const char *msg1, const char *msg2)
{
    json_w w;
    char text[160];
    size_t a = strlen(msg1), b = msg2 ? strlen(msg2) : 0u;
    if (a > 100u)
        a = 100u;
    if (b > 50u)
        b = 50u;
    memcpy(text, msg1, a);
    if (b)
        memcpy(text + a, msg2, b);
    text[a + b] = 0;
    json_init(&w, json_buf, sizeof json_buf);
    json_begin(&w, '{');
    json_key(&w, "error");
    json_str(&w, text);
    json_end(&w, '}');
    send_reply(cmd, status, &w);
}

static void write_channel(json_w *w, const board_channel *c)
{
    json_begin(w, '{');
    json_key(w, "name");
    json_str(w, c->name);
    json_key(w, "quantity");
    json_str(w, c->quantity);
    json_key(w, "unit");
    json_str(w, c->unit);
    json_key(w, "scale");
    json_f64(w, c->scale);
    json_key(w, "offset");
    json_f64(w, c->offset);
    json_key(w, "range_si");
    json_f64(w, c->range_si);
    json_key(w, "adc_bits");
    json_i64(w, c->adc_bits);
    json_key(w, "sensitivity");
    json_f64(w, c->sensitivity);
    json_key(w, "sensitivity_unit");
    json_str(w, c->sensitivity_unit);
    json_end(w, '}');
}

static void reply_info(const proto_msg *cmd)
{
    const board_info *bi = d.info;
    json_w w;
    json_init(&w, json_buf, sizeof json_buf);
    json_begin(&w, '{');
    json_key(&w, "model");
    json_str(&w, bi->model);
    json_key(&w, "serial");
    json_str(&w, bi->serial);
    json_key(&w, "firmware");
    json_str(&w, bi->firmware);
    json_key(&w, "protocol_version");
    json_i64(&w, PROTO_VERSION);
    json_key(&w, "rate_hz");
    json_f64(&w, rate_hz(d.osr_index));
    json_key(&w, "block_size");
    json_i64(&w, d.block_size);
    json_key(&w, "channel_mask");
    json_u64(&w, d.mask);
    json_key(&w, "channels");
    json_begin(&w, '[');
    for (unsigned i = 0; i < bi->n_channels; i++)
        write_channel(&w, &bi->channels[i]);
    json_end(&w, ']');
    json_key(&w, "rates_hz");
    json_begin(&w, '[');
    for (unsigned i = 0; i < bi->n_osr; i++)
        json_f64(&w, rate_hz(i));
    json_end(&w, ']');
    json_key(&w, "max_block_size");
    json_i64(&w, DAQ_MAX_BLOCK);
    json_key(&w, "scenario");
    const char *sc = source_scenario_json();
    if (sc)
        json_str(&w, sc);
    else
        json_null(&w);
    json_end(&w, '}');
    send_reply(cmd, PS_OK, &w);
}

static void reply_status(const proto_msg *cmd)
{
    json_w w;
    json_init(&w, json_buf, sizeof json_buf);
    json_begin(&w, '{');
    json_key(&w, "streaming");
    json_bool(&w, d.streaming);
    json_key(&w, "next_sample");
    json_u64(&w, d.streaming ? source_position() : d.next_sample);
    json_key(&w, "pending_samples");
    json_u64(&w, d.block_n);
    json_key(&w, "frames_sent");
    json_u64(&w, d.frames_sent);
    json_key(&w, "rate_hz");
    json_f64(&w, rate_hz(d.osr_index));
    json_key(&w, "overrun_frames");
    json_u64(&w, d.overrun_frames);
    json_key(&w, "fifo_bytes");
    json_u64(&w, fifo_used());
    json_key(&w, "uptime_ms");
    json_u64(&w, board_millis());
    json_end(&w, '}');
    send_reply(cmd, PS_OK, &w);
}

static void reply_u64(const proto_msg *cmd, const char *key, uint64_t v)
{
    json_w w;
    json_init(&w, json_buf, sizeof json_buf);
    json_begin(&w, '{');
    json_key(&w, key);
    json_u64(&w, v);
    if (cmd->type == PT_START) {
        json_key(&w, "started_at_s");
        json_f64(&w, (double)d.started_ms / 1000.0);
    }
    json_end(&w, '}');
    send_reply(cmd, PS_OK, &w);
}

/* ------------------------------------------------------------------ commands */

static void rates_text(char *out, size_t cap)
{
    json_w w;
    json_init(&w, out, cap);
    json_begin(&w, '[');
    for (unsigned i = 0; i < d.info->n_osr; i++)
        json_f64(&w, rate_hz(i));
    json_end(&w, ']');
    out[w.len] = 0;
}

static void do_configure(const proto_msg *cmd)
{
    if (cmd->body_len != 14u) {
        reply_error(cmd, PS_BAD_COMMAND, "configure body must be 14 bytes", 0);
        return;
    }
    if (d.streaming) {
        reply_error(cmd, PS_BAD_STATE, "configure while streaming: stop first", 0);
        return;
    }
    double want = proto_get_f64(cmd->body);
    uint32_t mask = proto_get_u32(cmd->body + 8);
    unsigned block = (unsigned)cmd->body[12] | ((unsigned)cmd->body[13] << 8);
    if (mask >> d.info->n_channels) {
        reply_error(cmd, PS_BAD_VALUE, "channel mask names channels this device does not have", 0);
        return;
    }
    if (block > DAQ_MAX_BLOCK) {
        reply_error(cmd, PS_BAD_VALUE, "block size must be 1..1024 samples", 0);
        return;
    }
    unsigned osr_index = d.osr_index;
    if (want != 0.0) {
        unsigned best = 0;
        double best_err = 1e300;
        for (unsigned i = 0; i < d.info->n_osr; i++) {
            double r = rate_hz(i);
            double err = (r > want ? r - want : want - r) / want;
            if (err < best_err) {
                best_err = err;
                best = i;
            }
        }
        if (!(want > 0.0) || best_err > 0.05) {
            char text[120];
            rates_text(text, sizeof text);
            reply_error(cmd, PS_BAD_VALUE, "rate must be within 5 % of one of (Hz) ", text);
            return;
        }
        osr_index = best;
    }
    if (mask)
        d.mask = mask;
    if (block)
        d.block_size = block;
    d.osr_index = osr_index;
    count_channels();
    d.next_sample = 0;
    d.block_n = 0;
    source_configure(osr_index);
    reply_info(cmd);
}

static void do_impact(const proto_msg *cmd)
{
    if (!d.info->has_hammer) {
        reply_error(cmd, PS_UNSUPPORTED, "this device has no hammer", 0);
        return;
    }
    if (cmd->body_len != 9u) {
        reply_error(cmd, PS_BAD_COMMAND, "impact body must be 9 bytes", 0);
        return;
    }
    const char *err = "impact refused";
    uint64_t at = source_impact(proto_get_f64(cmd->body), cmd->body[8] != 0, &err);
    if (at == UINT64_MAX) {
        reply_error(cmd, PS_BAD_VALUE, err, 0);
        return;
    }
    reply_u64(cmd, "at_sample", at);
}

static void handle(const proto_msg *cmd)
{
    if (cmd->version != PROTO_VERSION)
        return;   /* a host of another version: nothing it says can be trusted */
    switch (cmd->type) {
    case PT_IDENTIFY:
        reply_info(cmd);
        break;
    case PT_STATUS:
        reply_status(cmd);
        break;
    case PT_CONFIGURE:
        do_configure(cmd);
        break;
    case PT_START:
        if (!d.streaming) {
            d.streaming = 1;
            d.started_ms = board_millis();
            d.block_n = 0;
            source_start(d.next_sample);
        }
        reply_u64(cmd, "first_sample", d.next_sample);
        break;
    case PT_STOP: {
        if (d.streaming) {
            source_stop();
            take_rows();
            emit_block();
            uint64_t pos = source_position();
            if (pos > d.next_sample)
                d.next_sample = pos;   /* samples lost at the very end: the host counts them */
            d.streaming = 0;
        }
        reply_u64(cmd, "next_sample", d.next_sample);
        break;
    }
    case PT_IMPACT:
        do_impact(cmd);
        break;
    default:
        reply_error(cmd, PS_BAD_COMMAND, "unknown command type", 0);
        break;
    }
}

/* ------------------------------------------------------------------ main loop */

void daq_init(void)
{
    memset(&d, 0, sizeof d);
    d.info = board_get_info();
    d.mask = (1u << d.info->n_channels) - 1u;
    d.block_size = DAQ_DEFAULT_BLOCK;
    d.osr_index = d.info->default_osr_index;
    count_channels();
    proto_rx_init(&rx);
    source_configure(d.osr_index);
}

void daq_poll(void)
{
    uint8_t b;
    proto_msg msg;
    unsigned busy = 0;
    board_poll();
    for (int i = 0; i < 64 && board_rx(&b); i++) {
        busy = 1;
        if (proto_rx_byte(&rx, b, &msg))
            handle(&msg);
    }
    if (d.streaming)
        busy += take_rows();
    fifo_drain();
    if (!busy && !fifo_used())
        board_idle();
}
