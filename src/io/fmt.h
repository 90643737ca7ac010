/*
 * fmt.h -- numbers as text for the text formats, the bytes of printf's
 * without printf (fmt.c).
 */
#ifndef PA_IO_FMT_H
#define PA_IO_FMT_H

#include <stdint.h>

/* x in the form of printf's "%.*g" with precision prec into s (room for 32
 * chars), the same bytes as snprintf; its length. fmt.c. */
int pa__fmt_g(char *s, double x, int prec);
/* The shorter of x's "%.15g" and "%.17g" forms that reads back exactly
 * (strtod) into s (room for 32 chars); its length. fmt.c. */
int pa__fmt_shortest(char *s, double x);
/* v in decimal ("%lld") into s (room for 21 chars, not terminated); its
 * length. fmt.c. */
int pa__fmt_int(char *s, int64_t v);

#endif /* PA_IO_FMT_H */
