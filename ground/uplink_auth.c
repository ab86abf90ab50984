/* uplink_auth.c -- see uplink_auth.h. */
#include "ground/uplink_auth.h"
#include "ground/tc_sign.h"

#include <stdio.h>
#include <string.h>

int uplink_auth_open(uplink_auth_t *a, const char *key_path, uint32_t epoch, char *err, size_t err_size)
{
    memset(a, 0, sizeof *a);
    if (key_path == NULL) {
        return 0;
    }
    tc_auth_key_t keys[TC_AUTH_MAX_KEYS];
    unsigned n = 0;
    if (tc_auth_read_keys(key_path, keys, TC_AUTH_MAX_KEYS, &n, err, err_size) != 0) {
        return -1;
    }
    a->on = true;
    a->key = keys[0]; /* the first key signs (docs/uplink.md: rotation) */
    tc_auth_wipe(keys, sizeof keys);
    a->epoch = epoch;
    a->epoch_known = epoch != 0u;
    a->next_count = 1u;
    return 0;
}

bool uplink_auth_ready(const uplink_auth_t *a)
{
    return !a->on || a->epoch_known;
}

tc_status_t uplink_auth_frame(uplink_auth_t *a, const tc_cmd_t *cmd, uint16_t seq, uint8_t *out, size_t cap,
                              size_t *out_len)
{
    if (!a->on) {
        return tc_frame_encode(cmd, seq, out, cap, out_len);
    }
    if (!a->epoch_known || a->next_count == 0u) {
        return TC_E_STATE; /* not yet (or a count space used up: the board must reboot) */
    }
    const uint64_t arsn = (uint64_t)a->epoch << 32 | a->next_count;
    const tc_status_t st = tc_sign_frame(&a->key, cmd, seq, arsn, out, cap, out_len);
    if (st == TC_OK) {
        a->next_count++;
    }
    return st;
}

void uplink_auth_housekeeping(uplink_auth_t *a, const tlm_hk_t *hk)
{
    if (!a->on || hk->tc_epoch == 0u) {
        return; /* plain uplink, or the board does not authenticate */
    }
    if (!a->epoch_known || hk->tc_epoch != a->epoch) {
        if (a->epoch_known) {
            fprintf(stderr, "mfns-ground: the board's command epoch is now %u (was %u): signing for it\n",
                    hk->tc_epoch, a->epoch);
        }
        a->epoch = hk->tc_epoch;
        a->epoch_known = true;
        a->next_count = hk->tc_arsn_last + 1u;
        a->epoch_changes++;
    } else if (hk->tc_arsn_last >= a->next_count) {
        a->next_count = hk->tc_arsn_last + 1u; /* the board saw a later count (a restarted ground) */
    }
}

void uplink_auth_close(uplink_auth_t *a)
{
    tc_auth_wipe(a, sizeof *a);
}
