/* ch_css: the part of CSS that SVG editors write into <style> (docs/svg.md
 * "Stylesheets"): rules whose selectors are a type, classes and an id
 * (`.st0`, `path.cls-1`, `#logo`, `*`, and lists of them), with their
 * declarations and `!important`. Adobe Illustrator's default export
 * ("Internal CSS") gives every shape its paint this way.
 *
 * The cascade (CSS 2.2 §6.4.1, and SVG 1.1 §6.4 for presentation
 * attributes) from lowest to highest: presentation attributes, normal
 * declarations of matching rules by specificity and then order, the style
 * attribute, important declarations by specificity and order. The caller
 * applies attributes and the style attribute; ch_css_cascade gives the
 * rules' declarations of one importance in the order they apply. */
#ifndef CH_CSS_H
#define CH_CSS_H

#include "ch_error.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ch_css_selector {
  char *type; /* element name, or NULL for any */
  char *id;   /* or NULL */
  char **classes;
  int num_classes;
  int specificity; /* ids x 100 + classes x 10 + type */
} ch_css_selector;

typedef struct ch_css_decl {
  int selector;
  char *property; /* lower case */
  char *value;    /* trimmed, without !important */
  int important;
  int order; /* in the stylesheets' text */
} ch_css_decl;

typedef struct ch_css {
  ch_css_selector *selectors;
  int num_selectors, cap_selectors;
  ch_css_decl *decls; /* sorted by importance, specificity, order */
  int num_decls, cap_decls;
  int unsupported; /* selectors skipped (combinators, attributes, pseudo-classes) */
  char first_unsupported[64];
} ch_css;

/* Limits that turn an absurd stylesheet into an error. */
enum { CH_CSS_MAX_DECLS = 1 << 16 };

/* Adds the rules of a stylesheet's text. Rules with selectors it does not
 * read are skipped and counted; @-rules (@media, @font-face, ...) are
 * skipped whole. CH_ERR_INPUT past CH_CSS_MAX_DECLS declarations (the
 * message names `name`), CH_ERR_NOMEM. */
ch_status ch_css_parse(ch_css *css, const char *text, const char *name, ch_error *err);

/* Calls set(user, property, value) for every declaration of the given
 * importance whose selector matches an element (its name, id attribute
 * and class attribute, NULL where absent), in the order the cascade
 * applies them (a later call overrides an earlier one). */
void ch_css_cascade(const ch_css *css, const char *element, const char *id, const char *classes, int important,
                    void (*set)(void *user, const char *property, const char *value), void *user);

void ch_css_free(ch_css *css);

#ifdef __cplusplus
}
#endif
#endif
