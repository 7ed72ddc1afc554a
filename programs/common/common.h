/* common.h -- the room rayd-render and rayd-client share.
 *
 * Both programs are command lines on top of the core's public API, and
 * both need the same small things around it: a usage error said the same
 * way, getopt_long's refusals explained, numbers read strictly, the -o
 * file written whole or not at all, its format told by its name, and (the
 * client) base64 to embed files.  They live here once, in the manner of
 * Lua's lauxlib beside lapi: helpers over the public interface, never
 * inside it.  So this room uses only include/rayd/rayd.h and libc (no core
 * header, no libcurl, no cJSON), and only programs/render/ and
 * programs/client/ use it; tools/check_layers.py holds both rules.  The
 * server keeps its own option parser (server/config.c): it is a daemon
 * with one table of options, and never links this room.
 *
 *   prog.c         which program is running, and its one-line errors
 *   args.c         getopt_long's refusals said in full; strict numbers
 *   output.c       -o: a temporary file in the same folder, fsync, rename
 *   output_kind.c  the format an output's name asks for (.exr, .png, ...)
 *   part_guard.c   part files removed when a signal ends the program
 *   base64enc.c    base64 for the files the client embeds in a scene
 *   frame_name.c   --frames A-B, and frame k's file name from -o's %d
 *
 * Every name starts with its file's name.
 */
#ifndef RAYD_PROGRAMS_COMMON_H
#define RAYD_PROGRAMS_COMMON_H

#include <getopt.h>
#include <signal.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdio.h>
#include <sys/stat.h>
#include <sys/types.h>

/* ---- prog.c --------------------------------------------------------------- */

/* The program's name as its messages start ("rayd-render"): set once, by
 * main, before anything is said. */
void prog_init(const char *name);
/* One line on stderr: "NAME: error: " and the message. */
__attribute__((format(printf, 1, 2))) void prog_error(const char *fmt, ...);
/* A scene's path as an error names it first, as a compiler names a file:
 * "<stdin>" for "-" (output_name is the output's). */
const char *prog_input_name(const char *path);

/* ---- args.c --------------------------------------------------------------- */

/* A usage error: prog_error as an expression whose value is -1, seen at the
 * call: clang's analyzer does not follow calls into variadic functions, so a
 * function's -1 would be unknown to it (as err_set, core/base/error.h). */
#define args_bad(...) (prog_error(__VA_ARGS__), -1)

/* getopt_long's '?' (with opterr 0 and a leading ':' in the short options):
 * arg is the word it stopped at, opt its optopt (the short option, or a long
 * option's value when it was given one it does not take), opts the long
 * options.  Says which it was (a value it takes not, an ambiguous prefix,
 * naming the options it fits, or unknown).  args_unknown is the same as an
 * expression whose value is -1, seen at the call (as args_bad). */
void args_refused(const struct option *opts, const char *arg, int opt);
#define args_unknown(opts, arg, opt) (args_refused(opts, arg, opt), -1)
/* s as a whole integer in lo..hi into *out: 0, or -1 (nothing said). */
int args_long(const char *s, long lo, long hi, long *out);
/* s as a whole number (strtod's syntax) in lo..hi into *out: 0, or -1
 * (nothing said; NaN is never in range). */
int args_double(const char *s, double lo, double hi, double *out);

/* ---- output.c ------------------------------------------------------------- */

/* An output being written.  A regular file (new or replaced) is written as
 * a temporary file in its folder that becomes it only when whole (fsync,
 * rename): a reader never sees half an image, a failed or interrupted run
 * leaves the old file as it was (or none).  "-" is standard output; a
 * name that is no regular file (/dev/null, a FIFO) is written in place. */
struct output {
    FILE *f;       /* where the bytes go */
    char *tmp;     /* the temporary file, or NULL when written in place */
    char *target;  /* what tmp becomes: the path, or the file a link names */
    size_t len;    /* bytes written through output_put */
    int to_stdout; /* "-" */
};

/* A new temporary file beside target, *tmp its name (malloc'd, the
 * caller's): TARGET.PID.partEXT, O_EXCL so never one another run is
 * writing nor a link planted at the name; mode as the file it replaces
 * (old), else 0666 less the umask.  The fd, or -1 with errno and *tmp
 * NULL (EEXIST: the hundred names tried are all taken), so a caller that
 * removes *tmp removes only a file it made. */
int output_part(const char *target, const char *ext, const struct stat *old, char **tmp);
/* Opens path for writing ("-": standard output).  0, or -1 with errno. */
int output_open(struct output *o, const char *path);
/* Appends len bytes (the signature of the core's rayd_sink_fn).  0, or -1. */
int output_put(void *user, const void *buf, size_t len);
/* Makes the output whole: flushed, on disk, renamed into place.  0, or -1
 * with errno (then as output_abort: nothing left behind). */
int output_commit(struct output *o);
/* Gives up: the temporary file removed, the old file untouched; errno kept. */
void output_abort(struct output *o);
/* All of buf to path in one call; 0, or -1 after saying "cannot write". */
int output_write(const char *path, const void *buf, size_t len);
/* path as a message names it: "standard output" for "-". */
const char *output_name(const char *path);
/* Whether path's folder takes a new file: 0, or -1 said ("cannot write P:
 * why").  Asked before a render, so a folder that is missing is found
 * before the work, not after it. */
int output_writable(const char *path);

/* ---- part_guard.c --------------------------------------------------------- */

/* Holds SIGTERM, SIGINT and SIGHUP in this thread (the mask before into
 * *old), while a part file is made, guarded, renamed or removed;
 * part_guard_release puts the mask back. */
void part_guard_hold(sigset_t *old);
void part_guard_release(const sigset_t *old);
/* part is removed if one of those signals ends the program before
 * part_guard_disarm(part); false when it cannot be guarded (too many,
 * too long a name).  Signals held. */
bool part_guard_arm(const char *part);
/* The child writing the guarded files (0: none), killed first. */
void part_guard_child(pid_t pid);
void part_guard_disarm(const char *part);

/* ---- output_kind.c -------------------------------------------------------- */

/* The format an output file's name asks for by its extension, case
 * ignored: "exr" for .exr, "png" for .png and any name that is no image
 * format's ("-", "frame", "out.bin"), NULL for another image format's
 * (.jpg, .webp, .tiff, ...), which rayd does not write: a program then
 * refuses the name unless a format is given. */
const char *output_kind(const char *path);
/* Whether path names an OpenEXR file (output_kind "exr"). */
bool output_kind_exr(const char *path);

/* ---- frame_name.c --------------------------------------------------------- */

/* pattern with its one %d or %0Nd (N < 10) set to k, "%%" as "%",
 * into out.  -1 when the pattern has another % or more than one number (or
 * the name does not fit); 0 when it has none (out is the pattern), 1 when
 * it has one. */
int frame_name_path(const char *pattern, long k, char *out, size_t size);
/* What -o PATTERN's refusal (frame_name_path's -1) says after "-o %s: ",
 * as a printf format. */
#define FRAME_NAME_RULE                                                                            \
    "a frame's file takes one %%d (or %%0Nd, N < 10) and no other %% (%%%% for a %%)"
/* "A-B" (or "K"): frames, each in 0..1000000, A <= B.  0, or -1 (nothing
 * said). */
int frame_name_range(const char *s, long *a, long *b);

/* ---- base64enc.c ---------------------------------------------------------- */

/* Standard base64 with padding; malloc'd NUL-terminated string or NULL. */
char *base64enc(const unsigned char *data, size_t len);

#endif
