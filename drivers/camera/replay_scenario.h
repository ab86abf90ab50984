/* replay_scenario.h -- the check of a frame folder's scenario.json
 * (docs/nav-frames.md): the whole text must be one valid JSON object whose
 * top-level "format" is the string "mfns-nav-frames" and whose top-level
 * "version" is an integer literal from 1 to the version this reader knows.
 * Keys nested in inner objects never count; a duplicated top-level "format"
 * or "version" is refused. Pure (no I/O, no heap): the replay backend reads
 * the file and the fuzzer (tests/fuzz/fuzz_replay_scenario.c) calls this. */
#ifndef MFNS_REPLAY_SCENARIO_H
#define MFNS_REPLAY_SCENARIO_H

#include <stdbool.h>
#include <stddef.h>

#define MFNS_REPLAY_SCENARIO_VERSION 1        /* newest frame-folder version understood */
#define MFNS_REPLAY_SCENARIO_MAX (1u << 20)   /* bytes: far above any real scenario.json */
#define MFNS_REPLAY_JSON_MAX_DEPTH 64u        /* nesting of objects/arrays accepted */

/* true when json[0..n) is acceptable; otherwise why gets the one-line reason. */
bool mfns_replay_scenario_check(const char *json, size_t n, char *why, size_t why_size);

#endif
