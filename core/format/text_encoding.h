/* text_encoding.h -- naming a text file's encoding when it is not UTF-8. */
#ifndef TEXT_ENCODING_H
#define TEXT_ENCODING_H

#include <stdbool.h>
#include <stddef.h>

/* What the bytes are when they are text rayd cannot read: "UTF-16
 * (little-endian)", "UTF-32 (big-endian)", ... from a byte order mark, or
 * from NUL bytes in every other place of the first line; NULL when they
 * may be UTF-8 or ASCII. */
const char *text_foreign_encoding(const void *data, size_t len);

/* Whether the text's first line ends in a lone CR (the classic Mac OS
 * line ending), which readers that end lines at LF would take for one
 * line. */
bool text_lone_cr(const char *text, size_t len);
#define TEXT_LONE_CR                                                                               \
    "the lines end in a lone CR (classic Mac OS line endings); save the file with LF or CR LF "    \
    "line endings"

#endif
