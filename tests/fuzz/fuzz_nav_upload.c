/* libFuzzer target for the flight side of the table upload
 * (firmware/app/nav_upload.c): the input is a sequence of operations
 * (START / DATA / END / ABORT / tick / validate) with fuzzer-chosen
 * arguments, against a small receive buffer so that sizes near the bound
 * are reached.
 * Invariants after every operation: next <= size <= cap; the running CRC is
 * the CRC-32 of buf[0..next); a COMPLETE upload holds size bytes whose
 * CRC-32 is the declared one; IDLE means next == size == 0; a rejected DATA
 * leaves next unchanged; every status has a message; nothing reads or
 * writes outside the input and the buffer (ASan, UBSan).
 * Build: clang -fsanitize=fuzzer,address,undefined (mk/fuzz.mk). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "firmware/app/nav_upload.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FUZZ_CAP 2048u

static void check(int cond)
{
    if (!cond) {
        abort();
    }
}

static uint8_t g_buf[FUZZ_CAP];
static mfns_caltable_t g_table;

static uint32_t take_u32(const uint8_t **p, size_t *n, unsigned bytes)
{
    uint32_t v = 0;
    for (unsigned i = 0; i < bytes && *n > 0u; i++) {
        v = (v << 8) | **p;
        (*p)++;
        (*n)--;
    }
    return v;
}

static void invariants(const nav_upload_t *u)
{
    check(u->next <= u->size && u->size <= u->cap);
    check(u->crc_run == mfns_crc32(0, u->buf, u->next));
    if (u->state == NAV_UPLOAD_COMPLETE) {
        check(u->next == u->size && u->crc_run == u->crc_decl);
    }
    if (u->state == NAV_UPLOAD_IDLE) {
        check(u->next == 0u && u->size == 0u);
    }
    check(memchr(u->name, '\0', sizeof u->name) != NULL);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    nav_upload_t u;
    nav_upload_init(&u, g_buf, FUZZ_CAP, 50u);
    uint32_t now = 0;
    const uint8_t *p = data;
    size_t n = size;
    for (unsigned step = 0; n > 0u && step < 4096u; step++) {
        const uint8_t op = *p++;
        n--;
        nav_upload_status_t st = NAV_UP_OK;
        switch (op % 6u) {
        case 0: { /* START size(2) crc(4) namelen(1) name */
            const uint32_t sz = take_u32(&p, &n, 2);
            uint32_t crc = take_u32(&p, &n, 4);
            if ((crc & 1u) != 0u && u.state == NAV_UPLOAD_RECEIVING) {
                crc = u.crc_decl; /* reach resume sometimes */
            }
            char name[NAV_UPLOAD_NAME_MAX + 8u];
            const size_t nl = n > 0u ? (size_t)(take_u32(&p, &n, 1) % (sizeof name - 1u)) : 0u;
            const size_t got = nl < n ? nl : n;
            memcpy(name, p, got);
            name[got] = '\0';
            p += got;
            n -= got;
            st = nav_upload_start(&u, sz, crc, name, now);
            break;
        }
        case 1: { /* DATA offset(2) len(1) bytes */
            const uint32_t before = u.next;
            const uint32_t off = take_u32(&p, &n, 2);
            const size_t len = (size_t)take_u32(&p, &n, 1);
            const size_t got = len < n ? len : n;
            st = nav_upload_data(&u, off, got > 0u ? p : NULL, got, now);
            p += got;
            n -= got;
            if (st != NAV_UP_OK) {
                check(u.next == before);
            }
            break;
        }
        case 2:
            st = nav_upload_end(&u, now);
            break;
        case 3:
            st = nav_upload_abort(&u);
            break;
        case 4:
            now += take_u32(&p, &n, 1);
            st = nav_upload_tick(&u, now);
            break;
        default: {
            mfns_caltable_status_t ts = MFNS_CALTABLE_OK;
            const bool was_complete = u.state == NAV_UPLOAD_COMPLETE;
            st = nav_upload_validate(&u, &g_table, &ts);
            check(was_complete ? (st == NAV_UP_OK) == (ts == MFNS_CALTABLE_OK) : st == NAV_UP_E_STATE);
            break;
        }
        }
        check((unsigned)st < (unsigned)NAV_UP_STATUS_COUNT);
        check(strcmp(nav_upload_strerror(st), "unknown upload status") != 0);
        invariants(&u);
    }
    return 0;
}
