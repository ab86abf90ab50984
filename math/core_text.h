/* core_text.h -- whether the portable core carries its human-readable
 * messages (strerror texts, code names).
 *
 * Every decision of the core is reported by a numbered code, which is what the
 * telemetry carries; the texts only explain a code to a person at a console.
 * A flash-constrained bare-metal target without a console (boards/
 * cortex-m7-core) builds with -DMFNS_CORE_MESSAGES=0: each text is then "",
 * the literal is never emitted, and nothing else changes (the codes, the
 * checks and every return value are identical). Default: 1 (Linux and host
 * builds keep every message).
 */
#ifndef MFNS_CORE_TEXT_H
#define MFNS_CORE_TEXT_H

#ifndef MFNS_CORE_MESSAGES
#define MFNS_CORE_MESSAGES 1
#endif

#if MFNS_CORE_MESSAGES
#define MFNS_MSG(text) (text)
#else
#define MFNS_MSG(text) ("")
#endif

#endif /* MFNS_CORE_TEXT_H */
