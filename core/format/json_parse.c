/* json_parse.c -- the lock around cJSON's parse.
 *
 * cJSON writes a global error slot on every parse, so two threads parsing
 * at once race on it.  Every parse in the core (the scene, a glTF mesh's
 * document) goes through here and is serialised by one mutex; it is cheap
 * next to what is then built from the tree.  The text has passed
 * json_check first, so a failure here means out of memory.
 */
#include <pthread.h>

#include "format/json_parse.h"

static pthread_mutex_t cjson_lock = PTHREAD_MUTEX_INITIALIZER;

cJSON *json_parse_locked(const char *text, size_t len) {
    pthread_mutex_lock(&cjson_lock);
    cJSON *root = cJSON_ParseWithLength(text, len);
    pthread_mutex_unlock(&cjson_lock);
    return root;
}
