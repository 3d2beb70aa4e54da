/* A tiny JSON writer (see json.h). Output matches Python's json.dumps(separators=(",", ":"))
 * for the integers and strings the test vectors use. */
#include "json.h"

#include <string.h>

void json_init(json_w *w, char *buf, size_t cap)
{
    w->buf = buf;
    w->cap = cap;
    w->len = 0;
    w->need_comma = 0;
    w->overflow = 0;
}

static void put(json_w *w, char c)
{
    if (w->len + 1u < w->cap)
        w->buf[w->len++] = c;
    else
        w->overflow = 1;
}

static void puts_(json_w *w, const char *s)
{
    while (*s)
        put(w, *s++);
}

static void sep(json_w *w)
{
    if (w->need_comma)
        put(w, ',');
    w->need_comma = 1;
}

void json_begin(json_w *w, char open)
{
    sep(w);
    put(w, open);
    w->need_comma = 0;
}

void json_end(json_w *w, char close)
{
    put(w, close);
    w->need_comma = 1;
}

void json_key(json_w *w, const char *key)
{
    json_str(w, key);
    put(w, ':');
    w->need_comma = 0;
}

void json_str(json_w *w, const char *s)
{
    static const char hex[] = "0123456789abcdef";
    sep(w);
    put(w, '"');
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\') {
            put(w, '\\');
            put(w, (char)c);
        } else if (c < 0x20u) {
            puts_(w, "\\u00");
            put(w, hex[c >> 4]);
            put(w, hex[c & 15u]);
        } else {
            put(w, (char)c);
        }
    }
    put(w, '"');
}

static void put_u64(json_w *w, uint64_t v)
{
    char tmp[21];
    int n = 0;
    do {
        tmp[n++] = (char)('0' + (int)(v % 10u));
        v /= 10u;
    } while (v);
    while (n)
        put(w, tmp[--n]);
}

void json_u64(json_w *w, uint64_t v)
{
    sep(w);
    put_u64(w, v);
}

void json_i64(json_w *w, int64_t v)
{
    sep(w);
    if (v < 0) {
        put(w, '-');
        put_u64(w, (uint64_t)0 - (uint64_t)v);
    } else {
        put_u64(w, (uint64_t)v);
    }
}

void json_bool(json_w *w, int v)
{
    sep(w);
    puts_(w, v ? "true" : "false");
}

void json_null(json_w *w)
{
    sep(w);
    puts_(w, "null");
}

void json_raw(json_w *w, const char *s)
{
    sep(w);
    puts_(w, s);
}

void json_f64(json_w *w, double v)
{
    if (v != v || v > 1e308 || v < -1e308) {
        json_null(w);
        return;
    }
    sep(w);
    if (v < 0) {
        put(w, '-');
        v = -v;
    }
    if (v == 0.0) {
        puts_(w, "0.0");
        return;
    }
    /* v = m * 10^e with 1 <= m < 10, to 9 significant digits */
    int e = 0;
    while (v >= 10.0) {
        v /= 10.0;
        e++;
    }
    while (v < 1.0) {
        v *= 10.0;
        e--;
    }
    uint64_t digits = (uint64_t)(v * 1e8 + 0.5);
    if (digits >= 1000000000u) {
        digits /= 10u;
        e++;
    }
    char d[9];
    for (int i = 8; i >= 0; i--) {
        d[i] = (char)('0' + (int)(digits % 10u));
        digits /= 10u;
    }
    int last = 8;
    while (last > 0 && d[last] == '0')
        last--;
    if (e >= 0 && e < 9) {       /* plain: ddd.ddd */
        for (int i = 0; i <= e; i++)
            put(w, d[i]);
        put(w, '.');
        if (last <= e)
            put(w, '0');
        for (int i = e + 1; i <= last; i++)
            put(w, d[i]);
        return;
    }
    put(w, d[0]);            /* scientific: d.ddde-X */
    put(w, '.');
    if (last == 0)
        put(w, '0');
    for (int i = 1; i <= last; i++)
        put(w, d[i]);
    put(w, 'e');
    if (e < 0) {
        put(w, '-');
        e = -e;
    }
    put_u64(w, (uint64_t)e);
}
