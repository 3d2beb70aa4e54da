/* A tiny JSON writer for the REPLY frames (no printf, no heap). */
#ifndef EDDI_JSON_H
#define EDDI_JSON_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
    char *buf;
    size_t cap, len;
    int need_comma;
    int overflow;     /* set when something did not fit */
} json_w;

void json_init(json_w *w, char *buf, size_t cap);
void json_begin(json_w *w, char open);      /* '{' or '[' */
void json_end(json_w *w, char close);       /* '}' or ']' */
void json_key(json_w *w, const char *key);  /* "key": (the value follows) */
void json_str(json_w *w, const char *s);
void json_i64(json_w *w, int64_t v);
void json_u64(json_w *w, uint64_t v);
void json_f64(json_w *w, double v);         /* shortest of 9 significant digits; NaN/inf -> null */
void json_bool(json_w *w, int v);
void json_null(json_w *w);
void json_raw(json_w *w, const char *s);

#endif
