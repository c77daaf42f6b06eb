/* ch_css: simple selectors and declarations from <style> (see ch_css.h).
 * Tokenising follows CSS Syntax Level 3 loosely: comments are dropped,
 * blocks are found by matching braces (strings and parentheses kept
 * whole, so a `url(...)` or a quoted `;` does not end a declaration). */
#include "ch_css.h"

#include <stdlib.h>
#include <string.h>

static int is_space(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f'; }

static int is_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' || c == '_' ||
         (unsigned char)c >= 0x80;
}

static char lower(char c) { return c >= 'A' && c <= 'Z' ? (char)(c - 'A' + 'a') : c; }

/* A copy of s[0..n) without surrounding white space (lower case if asked). */
static char *dup_trim(const char *s, size_t n, int to_lower) {
  while (n && is_space(*s)) s++, n--;
  while (n && is_space(s[n - 1])) n--;
  char *d = malloc(n + 1);
  if (!d) return NULL;
  for (size_t i = 0; i < n; i++) d[i] = to_lower ? lower(s[i]) : s[i];
  d[n] = '\0';
  return d;
}

/* The text without comments (a new string). */
static char *strip_comments(const char *text) {
  size_t n = strlen(text);
  char *out = malloc(n + 1), *o = out;
  if (!out) return NULL;
  for (const char *p = text; *p;) {
    if (p[0] == '/' && p[1] == '*') {
      const char *e = strstr(p + 2, "*/");
      if (!e) break;
      p = e + 2;
      *o++ = ' ';
    } else {
      *o++ = *p++;
    }
  }
  *o = '\0';
  return out;
}

/* The end of a run of text up to one of the stop characters at depth 0
 * (outside strings, parentheses and brackets), or the end of the text. */
static const char *scan_to(const char *p, const char *stops) {
  int depth = 0;
  while (*p) {
    char c = *p;
    if (c == '"' || c == '\'') {
      const char *q = p + 1;
      while (*q && *q != c) q += q[0] == '\\' && q[1] ? 2 : 1;
      p = *q ? q + 1 : q;
      continue;
    }
    if (depth == 0 && strchr(stops, c)) return p;
    if (c == '(' || c == '[') depth++;
    if ((c == ')' || c == ']') && depth > 0) depth--;
    p++;
  }
  return p;
}

/* Skips a {...} block with nested blocks; p at '{'. */
static const char *skip_block(const char *p) {
  int depth = 0;
  while (*p) {
    p = scan_to(p, "{}");
    if (!*p) break;
    depth += *p == '{' ? 1 : -1;
    p++;
    if (depth == 0) break;
  }
  return p;
}

static void free_selector(ch_css_selector *s) {
  free(s->type);
  free(s->id);
  for (int i = 0; i < s->num_classes; i++) free(s->classes[i]);
  free(s->classes);
  memset(s, 0, sizeof *s);
}

/* Parses one simple selector (type, then .class and #id parts) from s[0..n).
 * Returns 1, 0 for a selector it does not read, -1 out of memory. */
static int parse_selector(const char *s, size_t n, ch_css_selector *out) {
  memset(out, 0, sizeof *out);
  while (n && is_space(*s)) s++, n--;
  while (n && is_space(s[n - 1])) n--;
  if (n == 0) return 0;
  const char *p = s, *end = s + n;
  if (*p == '*') {
    p++;
  } else if (is_name_char(*p)) {
    const char *q = p;
    while (q < end && is_name_char(*q)) q++;
    if (!(out->type = dup_trim(p, (size_t)(q - p), 0))) return -1;
    p = q;
  }
  while (p < end) {
    char kind = *p++;
    const char *q = p;
    while (q < end && is_name_char(*q)) q++;
    if ((kind != '.' && kind != '#') || q == p) {
      free_selector(out);
      return 0; /* a combinator, an attribute selector, a pseudo-class ... */
    }
    char *name = dup_trim(p, (size_t)(q - p), 0);
    if (!name) {
      free_selector(out);
      return -1;
    }
    if (kind == '#') {
      if (out->id) { /* two ids: matches nothing an element can have */
        free(name);
        free_selector(out);
        return 0;
      }
      out->id = name;
      out->specificity += 100;
    } else {
      char **c = realloc(out->classes, (size_t)(out->num_classes + 1) * sizeof *c);
      if (!c) {
        free(name);
        free_selector(out);
        return -1;
      }
      out->classes = c;
      out->classes[out->num_classes++] = name;
      out->specificity += 10;
    }
    p = q;
  }
  if (out->type) out->specificity += 1;
  return 1;
}

/* The selectors' specificities, for sorting without a context pointer. */
typedef struct keyed {
  ch_css_decl d;
  int specificity;
} keyed;

static int cmp_keyed(const void *x, const void *y) {
  const keyed *a = x, *b = y;
  if (a->d.important != b->d.important) return a->d.important < b->d.important ? -1 : 1;
  if (a->specificity != b->specificity) return a->specificity < b->specificity ? -1 : 1;
  return (a->d.order > b->d.order) - (a->d.order < b->d.order);
}

static ch_status no_memory(ch_error *err, const char *name) {
  return ch_error_set(err, CH_ERR_NOMEM, "%s: out of memory reading a stylesheet", name);
}

/* Adds the declarations of one block for the selectors [first, first + n). */
static ch_status add_block(ch_css *css, const char *p, const char *end, int first, int n, const char *name,
                           ch_error *err) {
  ch_status st = CH_OK;
  while (p < end) {
    const char *e = scan_to(p, ";");
    if (e > end) e = end;
    const char *colon = memchr(p, ':', (size_t)(e - p));
    if (colon) {
      char *prop = dup_trim(p, (size_t)(colon - p), 1);
      char *value = dup_trim(colon + 1, (size_t)(e - colon - 1), 0);
      if (!prop || !value) {
        free(prop), free(value);
        return no_memory(err, name);
      }
      int important = 0;
      char *bang = strrchr(value, '!');
      if (bang) {
        char *w = bang + 1;
        while (is_space(*w)) w++;
        char kw[10] = "";
        for (int i = 0; i < 9 && w[i]; i++) kw[i] = lower(w[i]);
        if (strncmp(kw, "important", 9) == 0) {
          important = 1;
          *bang = '\0';
          for (size_t k = strlen(value); k && is_space(value[k - 1]); k--) value[k - 1] = '\0';
        }
      }
      for (int s = first; !st && s < first + n; s++) {
        if (css->num_decls >= CH_CSS_MAX_DECLS) {
          st = ch_error_set(err, CH_ERR_INPUT, "%s: a stylesheet with more than %d declarations", name,
                            CH_CSS_MAX_DECLS);
          break;
        }
        if (css->num_decls == css->cap_decls) {
          int cap = css->cap_decls ? 2 * css->cap_decls : 64;
          ch_css_decl *d = realloc(css->decls, (size_t)cap * sizeof *d);
          if (!d) {
            st = no_memory(err, name);
            break;
          }
          css->decls = d, css->cap_decls = cap;
        }
        ch_css_decl *d = &css->decls[css->num_decls];
        d->selector = s;
        d->important = important;
        d->order = css->num_decls;
        d->property = dup_trim(prop, strlen(prop), 0);
        d->value = dup_trim(value, strlen(value), 0);
        if (!d->property || !d->value) {
          free(d->property), free(d->value);
          st = no_memory(err, name);
          break;
        }
        css->num_decls++;
      }
      free(prop), free(value);
      if (st) return st;
    }
    p = *e == ';' ? e + 1 : e;
  }
  return CH_OK;
}

ch_status ch_css_parse(ch_css *css, const char *text, const char *name, ch_error *err) {
  char *clean = strip_comments(text);
  if (!clean) return no_memory(err, name);
  ch_status st = CH_OK;
  const char *p = clean;
  while (!st && *p) {
    while (is_space(*p)) p++;
    if (!*p) break;
    if (*p == '@') { /* an at-rule: to its ';' or past its block */
      const char *e = scan_to(p, ";{");
      p = *e == '{' ? skip_block(e) : *e ? e + 1 : e;
      continue;
    }
    if (*p == '}') { /* a stray brace */
      p++;
      continue;
    }
    const char *open = scan_to(p, "{");
    if (!*open) break;
    const char *close = scan_to(open + 1, "}");
    /* the selector list: each one read or skipped on its own */
    int first = css->num_selectors, n = 0;
    for (const char *s = p; s < open && !st;) {
      const char *comma = scan_to(s, ",{");
      if (comma > open) comma = open;
      ch_css_selector sel;
      int r = parse_selector(s, (size_t)(comma - s), &sel);
      if (r < 0) {
        st = no_memory(err, name);
      } else if (r == 0) {
        size_t len = (size_t)(comma - s);
        while (len && is_space(*s)) s++, len--;
        while (len && is_space(s[len - 1])) len--;
        if (len && css->unsupported++ == 0) {
          size_t k = len < sizeof css->first_unsupported - 1 ? len : sizeof css->first_unsupported - 1;
          memcpy(css->first_unsupported, s, k);
          css->first_unsupported[k] = '\0';
        }
      } else {
        if (css->num_selectors == css->cap_selectors) {
          int cap = css->cap_selectors ? 2 * css->cap_selectors : 16;
          ch_css_selector *a = realloc(css->selectors, (size_t)cap * sizeof *a);
          if (!a) {
            free_selector(&sel);
            st = no_memory(err, name);
            break;
          }
          css->selectors = a, css->cap_selectors = cap;
        }
        css->selectors[css->num_selectors++] = sel;
        n++;
      }
      s = comma < open ? comma + 1 : open;
    }
    if (!st) st = add_block(css, open + 1, close, first, n, name, err);
    p = *close ? close + 1 : close;
  }
  free(clean);
  if (st || css->num_decls < 2) return st;
  /* the order the cascade applies them in */
  keyed *k = malloc((size_t)css->num_decls * sizeof *k);
  if (!k) return no_memory(err, name);
  for (int i = 0; i < css->num_decls; i++)
    k[i] = (keyed){css->decls[i], css->selectors[css->decls[i].selector].specificity};
  qsort(k, (size_t)css->num_decls, sizeof *k, cmp_keyed);
  for (int i = 0; i < css->num_decls; i++) css->decls[i] = k[i].d;
  free(k);
  return CH_OK;
}

/* Whether the white-space separated list has the token. */
static int has_token(const char *list, const char *token) {
  size_t n = strlen(token);
  for (const char *p = list; *p;) {
    while (is_space(*p)) p++;
    const char *q = p;
    while (*q && !is_space(*q)) q++;
    if ((size_t)(q - p) == n && strncmp(p, token, n) == 0) return 1;
    p = q;
  }
  return 0;
}

static int matches(const ch_css_selector *s, const char *element, const char *id, const char *classes) {
  if (s->type && (!element || strcmp(s->type, element) != 0)) return 0;
  if (s->id && (!id || strcmp(s->id, id) != 0)) return 0;
  for (int i = 0; i < s->num_classes; i++)
    if (!classes || !has_token(classes, s->classes[i])) return 0;
  return 1;
}

void ch_css_cascade(const ch_css *css, const char *element, const char *id, const char *classes, int important,
                    void (*set)(void *user, const char *property, const char *value), void *user) {
  for (int i = 0; i < css->num_decls; i++) {
    const ch_css_decl *d = &css->decls[i];
    if (d->important == important && matches(&css->selectors[d->selector], element, id, classes))
      set(user, d->property, d->value);
  }
}

void ch_css_free(ch_css *css) {
  for (int i = 0; i < css->num_selectors; i++) free_selector(&css->selectors[i]);
  for (int i = 0; i < css->num_decls; i++) free(css->decls[i].property), free(css->decls[i].value);
  free(css->selectors);
  free(css->decls);
  memset(css, 0, sizeof *css);
}
