/* tc_sign.c -- see tc_sign.h. */
#include "ground/tc_sign.h"

tc_status_t tc_sign_frame(const tc_auth_key_t *key, const tc_cmd_t *cmd, uint16_t seq, uint64_t arsn,
                          uint8_t *out, size_t cap, size_t *out_len)
{
    if (key == NULL) {
        return TC_E_NULL;
    }
    uint8_t pkt[TC_MAX_SEC_PACKET];
    size_t n = 0;
    const tc_status_t st = tc_sec_packet_encode(cmd, seq, key->id, arsn, pkt, sizeof pkt, &n);
    if (st != TC_OK) {
        return st;
    }
    if (tc_auth_mac(key->key, pkt, n, pkt + n) != 0) {
        return TC_E_NULL;
    }
    return tc_packet_frame(pkt, n + TC_SEC_MAC_LEN, out, cap, out_len);
}
