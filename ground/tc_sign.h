/* tc_sign.h -- the ground's half of the telecommand authentication
 * (docs/uplink.md 1a): the wire frame of a command with its security header
 * and truncated HMAC, as firmware/linux/tc_auth.c checks it. Ground only: the
 * flight program verifies commands and never signs one, so this lives out of
 * the flight folders and out of the flight image (issue 22). */
#ifndef MFNS_GROUND_TC_SIGN_H
#define MFNS_GROUND_TC_SIGN_H

#include <stddef.h>
#include <stdint.h>

#include "firmware/linux/tc_auth.h"
#include "firmware/tlm/tc_packets.h"

/* The wire frame of cmd signed with key (id = SPI) and arsn into out[0..cap).
 * TC_OK, or the codec's status (TC_E_NULL also when the MAC failed). */
tc_status_t tc_sign_frame(const tc_auth_key_t *key, const tc_cmd_t *cmd, uint16_t seq, uint64_t arsn, uint8_t *out,
                          size_t cap, size_t *out_len);

#endif /* MFNS_GROUND_TC_SIGN_H */
