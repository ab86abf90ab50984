/* tlm_err.h -- error codes of the telemetry codec (firmware/tlm) and their
 * one-line messages. Every codec function that can fail returns one of these;
 * 0 is success, failures are negative so a caller can test `< 0`.
 */
#ifndef MFNS_TLM_ERR_H
#define MFNS_TLM_ERR_H

typedef enum {
    TLM_OK = 0,
    TLM_ERR_NULL = -1,      /* a required pointer argument is NULL */
    TLM_ERR_BUFFER = -2,    /* output buffer too small */
    TLM_ERR_COBS = -3,      /* COBS structure broken: a block runs past the frame end (truncated) */
    TLM_ERR_CRC = -4,       /* frame CRC-16/CCITT-FALSE mismatch */
    TLM_ERR_OVERSIZE = -5,  /* frame longer than TLM_MAX_FRAME before its delimiter */
    TLM_ERR_RUNT = -6,      /* frame shorter than a header + CRC (truncated) */
    TLM_ERR_HEADER = -7,    /* CCSDS primary header: bad version, type, flags or no secondary header */
    TLM_ERR_LENGTH = -8,    /* CCSDS packet length field disagrees with the frame length */
    TLM_ERR_APID = -9,      /* APID not one of the MFNS packet types */
    TLM_ERR_PAYLOAD = -10,  /* payload size wrong for its packet type, or a field out of range */
    TLM_ERR_ARG = -11,      /* an argument is out of range (e.g. APID > 2047, sequence > 16383) */
    TLM_ERR_EMPTY = -12,    /* transmit queue empty */
} tlm_err_t;

/* A one-line English message for any value above (never NULL; unknown codes
 * give "unknown telemetry error"). */
const char *tlm_strerror(int err);

#endif /* MFNS_TLM_ERR_H */
