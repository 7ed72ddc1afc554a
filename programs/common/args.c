/* args.c -- the command line's helpers: getopt_long's refusals said in
 * full, and numbers read strictly.
 *
 * Both programs parse with getopt_long, opterr 0 and a leading ':' in the
 * short options, so that every refusal is theirs to word.  getopt_long
 * hands back '?' for three different mistakes: an unknown option, a value
 * given to an option that takes none ("--quiet=1"), and a prefix of more
 * than one long option ("--pa" for --parallel and --passes); args_unknown
 * tells them apart and names the candidates.  Each program words its own
 * "takes an integer in ..." messages (they name the option's meaning), so
 * the number readers below only read: the whole string, in range, or -1.
 */
#include "common/common.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>

/* The long options of opts that word ("--na" or "--na=value") is a prefix
 * of, as "--name, --namesake" into out; how many. */
static int args_prefix_of(const struct option *opts, const char *word, char *out, size_t size) {
    size_t len = strcspn(word + 2, "="), used = 0;
    int n = 0;
    out[0] = '\0';
    for (const struct option *o = opts; o->name; o++) {
        if (strncmp(o->name, word + 2, len) != 0) continue;
        int k = snprintf(out + used, size - used, "%s--%s", n ? ", " : "", o->name);
        if (k > 0 && (size_t)k < size - used) used += (size_t)k;
        n++;
    }
    return n;
}

void args_refused(const struct option *opts, const char *arg, int opt) {
    char names[512];
    if (!strncmp(arg, "--", 2) && opt)
        prog_error("option '%.*s' takes no value", (int)strcspn(arg, "="), arg);
    else if (!strncmp(arg, "--", 2) && args_prefix_of(opts, arg, names, sizeof names) > 1)
        prog_error("ambiguous option '%s' (%s)", arg, names);
    else if (!strncmp(arg, "--", 2))
        prog_error("unknown option '%s'", arg);
    else
        prog_error("unknown option '-%c'", opt);
}

int args_long(const char *s, long lo, long hi, long *out) {
    char *end;
    errno = 0;
    long v = s ? strtol(s, &end, 10) : 0;
    if (!s || errno || end == s || *end || v < lo || v > hi) return -1;
    *out = v;
    return 0;
}

int args_double(const char *s, double lo, double hi, double *out) {
    char *end;
    errno = 0;
    double d = s ? strtod(s, &end) : 0;
    if (!s || end == s || *end || errno || !(d >= lo && d <= hi)) return -1;
    *out = d;
    return 0;
}
