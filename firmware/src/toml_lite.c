/* TOML subset reader: see toml_lite.h. */
#include "toml_lite.h"

#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef struct {
    const char *p, *end;
    int line;
    char *why;
    size_t why_len;
} cursor_t;

static bool fail(cursor_t *c, const char *reason)
{
    snprintf(c->why, c->why_len, "line %d: %s", c->line, reason);
    return false;
}

/* spaces and tabs (not newlines) */
static void skip_ws(cursor_t *c)
{
    while (c->p < c->end && (*c->p == ' ' || *c->p == '\t'))
        c->p++;
}

/* spaces, newlines and comments (inside arrays) */
static void skip_ws_nl(cursor_t *c)
{
    for (;;) {
        skip_ws(c);
        if (c->p < c->end && *c->p == '#') {
            while (c->p < c->end && *c->p != '\n')
                c->p++;
        }
        if (c->p < c->end && (*c->p == '\n' || *c->p == '\r')) {
            if (*c->p == '\n')
                c->line++;
            c->p++;
            continue;
        }
        return;
    }
}

/* end of line: whitespace, an optional comment, then a newline or the end */
static bool end_of_line(cursor_t *c)
{
    skip_ws(c);
    if (c->p < c->end && *c->p == '#')
        while (c->p < c->end && *c->p != '\n')
            c->p++;
    if (c->p < c->end && *c->p == '\r')
        c->p++;
    if (c->p < c->end && *c->p != '\n')
        return fail(c, "unexpected text after the value");
    return true;
}

static bool parse_string(cursor_t *c, char *out, size_t cap)
{
    char quote = *c->p++;
    size_t k = 0;
    if (c->end - c->p >= 2 && c->p[0] == quote && c->p[1] == quote)
        return fail(c, "multi-line strings are not supported here");
    while (c->p < c->end && *c->p != quote) {
        char ch = *c->p++;
        if (ch == '\n')
            return fail(c, "string not closed on its line");
        if (quote == '"' && ch == '\\') {
            if (c->p >= c->end)
                return fail(c, "string not closed");
            ch = *c->p++;
            switch (ch) {
            case 'n': ch = '\n'; break;
            case 't': ch = '\t'; break;
            case 'r': ch = '\r'; break;
            case 'b': ch = '\b'; break;
            case 'f': ch = '\f'; break;
            case '"': case '\\': break;
            case 'u': {
                unsigned cp = 0;
                for (int i = 0; i < 4; i++) {
                    if (c->p >= c->end || !isxdigit((unsigned char)*c->p))
                        return fail(c, "bad \\u escape");
                    cp = cp * 16 + (unsigned)(isdigit((unsigned char)*c->p) ? *c->p - '0'
                                                                            : (tolower((unsigned char)*c->p) - 'a' + 10));
                    c->p++;
                }
                if (cp > 0x7F)
                    return fail(c, "only ASCII \\u escapes are supported here");
                ch = (char)cp;
                break;
            }
            default: return fail(c, "unknown escape in a string");
            }
        }
        if (k + 1 >= cap)
            return fail(c, "string too long");
        out[k++] = ch;
    }
    if (c->p >= c->end)
        return fail(c, "string not closed");
    c->p++;
    out[k] = '\0';
    return true;
}

static bool parse_scalar(cursor_t *c, toml_scalar_t *v)
{
    char tok[64];
    size_t k = 0;
    memset(v, 0, sizeof *v);
    if (c->p >= c->end)
        return fail(c, "value missing");
    if (*c->p == '"' || *c->p == '\'') {
        v->type = TV_STRING;
        return parse_string(c, v->s, sizeof v->s);
    }
    if (*c->p == '{')
        return fail(c, "inline tables are not supported here");
    while (c->p < c->end && (isalnum((unsigned char)*c->p) || strchr("+-._:", *c->p)) && k + 1 < sizeof tok)
        tok[k++] = *c->p++;
    tok[k] = '\0';
    if (!k)
        return fail(c, "value missing");
    if (!strcmp(tok, "true") || !strcmp(tok, "false")) {
        v->type = TV_BOOL;
        v->b = tok[0] == 't';
        return true;
    }
    {
        char clean[64];
        size_t m = 0;
        const char *s = tok;
        bool is_float;
        for (size_t i = 0; i < k; i++)
            if (tok[i] != '_')
                clean[m++] = tok[i];
        clean[m] = '\0';
        s = clean;
        if (*s == '+' || *s == '-')
            s++;
        if (s[0] == '0' && (s[1] == 'x' || s[1] == 'o' || s[1] == 'b')) {
            int base = s[1] == 'x' ? 16 : s[1] == 'o' ? 8 : 2;
            char *endp;
            errno = 0;
            v->type = TV_INT;
            v->i = strtoll(s + 2, &endp, base);
            if (*endp || errno || s != clean)
                return fail(c, "bad integer");
            return true;
        }
        is_float = strpbrk(s, ".eE") != NULL || !strcmp(s, "inf") || !strcmp(s, "nan");
        if (strchr(clean, ':'))
            return fail(c, "dates and times are not supported here");
        if (is_float) {
            char *endp;
            v->type = TV_FLOAT;
            if (!strcmp(s, "inf") || !strcmp(s, "nan")) {
                v->f = s[0] == 'i' ? INFINITY : NAN;
                if (clean[0] == '-')
                    v->f = -v->f;
                return true;
            }
            v->f = strtod(clean, &endp);
            if (*endp || !isdigit((unsigned char)*s))
                return fail(c, "bad number");
            return true;
        }
        {
            char *endp;
            errno = 0;
            v->type = TV_INT;
            v->i = strtoll(clean, &endp, 10);
            if (*endp || errno || !isdigit((unsigned char)*s))
                return fail(c, "bad value (strings need quotes)");
        }
    }
    return true;
}

static bool parse_value(cursor_t *c, toml_value_t *v)
{
    memset(v, 0, sizeof *v);
    if (c->p < c->end && *c->p == '[') {
        c->p++;
        v->type = TV_ARRAY;
        for (;;) {
            toml_scalar_t item;
            skip_ws_nl(c);
            if (c->p < c->end && *c->p == ']') {
                c->p++;
                return true;
            }
            if (c->p < c->end && *c->p == '[')
                return fail(c, "nested arrays are not supported here");
            if (!parse_scalar(c, &item))
                return false;
            if (item.type == TV_STRING && strlen(item.s) >= TOML_ITEM_STR_MAX)
                return fail(c, "strings in arrays longer than 15 characters are not supported here");
            if (v->n < TOML_ARRAY_MAX) {
                toml_item_t *it = &v->items[v->n];
                it->type = item.type;
                memcpy(it->s, item.s, TOML_ITEM_STR_MAX);
                it->s[TOML_ITEM_STR_MAX - 1] = '\0';
                it->i = item.i;
                it->f = item.f;
                it->b = item.b;
            }
            v->n++;
            skip_ws_nl(c);
            if (c->p < c->end && *c->p == ',') {
                c->p++;
                continue;
            }
            if (c->p < c->end && *c->p == ']') {
                c->p++;
                return true;
            }
            return fail(c, "array not closed");
        }
    }
    if (!parse_scalar(c, &v->v))
        return false;
    v->type = v->v.type;
    return true;
}

/* a dotted key: bare (A-Za-z0-9_-) or quoted parts */
static bool parse_key(cursor_t *c, char *out, size_t cap)
{
    size_t k = 0;
    for (;;) {
        char part[TOML_KEY_MAX];
        size_t m = 0;
        skip_ws(c);
        if (c->p < c->end && (*c->p == '"' || *c->p == '\'')) {
            if (!parse_string(c, part, sizeof part))
                return false;
            m = strlen(part);
        } else {
            while (c->p < c->end && (isalnum((unsigned char)*c->p) || *c->p == '_' || *c->p == '-') &&
                   m + 1 < sizeof part)
                part[m++] = *c->p++;
            part[m] = '\0';
        }
        if (!m)
            return fail(c, "key missing");
        if (k + m + 2 >= cap)
            return fail(c, "key too long");
        if (k)
            out[k++] = '.';
        memcpy(out + k, part, m);
        k += m;
        out[k] = '\0';
        skip_ws(c);
        if (c->p < c->end && *c->p == '.') {
            c->p++;
            continue;
        }
        return true;
    }
}

bool toml_parse(const char *text, size_t len, toml_fn fn, void *ctx, char *why, size_t why_len)
{
    cursor_t c = {text, text + len, 1, why, why_len};
    char table[TOML_KEY_MAX] = "";
    for (;;) {
        skip_ws_nl(&c);
        if (c.p >= c.end)
            return true;
        if (*c.p == '[') {
            toml_value_t header;
            c.p++;
            if (c.p < c.end && *c.p == '[')
                return fail(&c, "arrays of tables are not supported here");
            if (!parse_key(&c, table, sizeof table))
                return false;
            if (c.p >= c.end || *c.p != ']')
                return fail(&c, "table header not closed");
            c.p++;
            if (!end_of_line(&c))
                return false;
            memset(&header, 0, sizeof header);
            header.type = TV_TABLE;
            if (!fn(ctx, table, &header))
                return false;
            continue;
        }
        {
            char key[TOML_KEY_MAX], full[2 * TOML_KEY_MAX];
            toml_value_t value;
            if (!parse_key(&c, key, sizeof key))
                return false;
            if (c.p >= c.end || *c.p != '=')
                return fail(&c, "expected '=' after the key");
            c.p++;
            skip_ws(&c);
            if (!parse_value(&c, &value) || !end_of_line(&c))
                return false;
            if (table[0])
                snprintf(full, sizeof full, "%s.%s", table, key);
            else
                snprintf(full, sizeof full, "%s", key);
            if (!fn(ctx, full, &value))
                return false;
        }
    }
}

void toml_float_repr(double f, char *out, size_t cap)
{
    if (isnan(f)) {
        snprintf(out, cap, "nan");
        return;
    }
    if (isinf(f)) {
        snprintf(out, cap, f > 0 ? "inf" : "-inf");
        return;
    }
    if (f == floor(f) && fabs(f) < 1e16) { /* Python writes integral floats in full, with ".0" */
        snprintf(out, cap, "%.1f", f);
        return;
    }
    for (int prec = 1; prec <= 17; prec++) { /* the shortest that reads back, as Python */
        snprintf(out, cap, "%.*g", prec, f);
        if (strtod(out, NULL) == f)
            break;
    }
    /* %g writes exponents as Python does (1e-05, 1.5e+16) */
}

static void repr_scalar(const toml_scalar_t *v, char *out, size_t cap)
{
    switch (v->type) {
    case TV_STRING: snprintf(out, cap, "'%s'", v->s); break;
    case TV_INT: snprintf(out, cap, "%lld", (long long)v->i); break;
    case TV_BOOL: snprintf(out, cap, "%s", v->b ? "True" : "False"); break;
    case TV_FLOAT: toml_float_repr(v->f, out, cap); break;
    default: snprintf(out, cap, "?"); break;
    }
}

void toml_repr(const toml_value_t *v, char *out, size_t cap)
{
    if (v->type == TV_TABLE) {
        snprintf(out, cap, "{...}");
        return;
    }
    if (v->type != TV_ARRAY) {
        repr_scalar(&v->v, out, cap);
        return;
    }
    {
        size_t k = 0;
        k += (size_t)snprintf(out + k, cap - k, "[");
        for (size_t i = 0; i < v->n && i < TOML_ARRAY_MAX && k < cap; i++) {
            char item[48];
            toml_scalar_t one;
            const toml_item_t *it = &v->items[i];
            one.type = it->type;
            memcpy(one.s, it->s, TOML_ITEM_STR_MAX);
            one.i = it->i;
            one.f = it->f;
            one.b = it->b;
            repr_scalar(&one, item, sizeof item);
            k += (size_t)snprintf(out + k, cap - k, "%s%s", i ? ", " : "", item);
        }
        if (k < cap)
            snprintf(out + k, cap - k, "%s]", v->n > TOML_ARRAY_MAX ? ", ..." : "");
    }
}
