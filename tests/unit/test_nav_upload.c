/* Unit tests of the flight side of the table upload (firmware/app/nav_upload.h):
 * the default table (build/gen/default.mfnstbl) sent in segments in order,
 * out of order (a gap refused, resent from next), duplicated, overlapping,
 * oversized; a bad CRC; a file with the right CRC that the table loader
 * refuses; abort, timeout, a replacing START, a resuming START; the atomic
 * store (file equal byte for byte, no temp left). */
#define _DEFAULT_SOURCE /* mkdtemp under -std=c11 */
#include "tests/unit/support/testutil.h"

#include <errno.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "firmware/app/nav_upload.h"

static uint8_t g_file[MFNS_CALTABLE_MAX_BYTES];
static uint32_t g_size;
static uint8_t g_rx[MFNS_CALTABLE_MAX_BYTES];
static mfns_caltable_t g_table;
static nav_upload_t g_u;

static int load_default(void **state)
{
    (void)state;
    const size_t n = mfns_test_read_gen("default.mfnstbl", g_file, sizeof g_file);
    g_size = (uint32_t)n;
    return n > 0u ? 0 : -1;
}

static int fresh(void **state)
{
    (void)state;
    memset(g_rx, 0, sizeof g_rx);
    nav_upload_init(&g_u, g_rx, sizeof g_rx, 1000u);
    return 0;
}

static uint32_t file_crc(void)
{
    return mfns_crc32(0, g_file, g_size);
}

/* sends [from, to) in segments of seg bytes; every one must be accepted as new */
static void send_range(uint32_t from, uint32_t to, uint32_t seg, uint32_t now)
{
    for (uint32_t off = from; off < to; off += seg) {
        const uint32_t n = to - off < seg ? to - off : seg;
        assert_int_equal(nav_upload_data(&g_u, off, g_file + off, n, now), NAV_UP_OK);
        assert_int_equal(nav_upload_next(&g_u), off + n);
    }
}

static void test_in_order_loads(void **state)
{
    (void)state;
    assert_true(g_size > 4u * NAV_UPLOAD_SEG_MAX);
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "cal-7.mfnstbl", 0), NAV_UP_OK);
    send_range(0, g_size, NAV_UPLOAD_SEG_MAX, 1);
    assert_int_equal(nav_upload_end(&g_u, 2), NAV_UP_OK);
    assert_int_equal(g_u.state, NAV_UPLOAD_COMPLETE);
    assert_int_equal(nav_upload_end(&g_u, 2), NAV_UP_DUPLICATE); /* END re-sent */
    mfns_caltable_status_t ts = MFNS_CALTABLE_E_IMAGE_SIZE;
    assert_int_equal(nav_upload_validate(&g_u, &g_table, &ts), NAV_UP_OK);
    assert_int_equal(ts, MFNS_CALTABLE_OK);
    assert_int_equal(g_table.size_bytes, g_size);
    assert_memory_equal(g_rx, g_file, g_size);
}

static void test_gap_refused_then_resent(void **state)
{
    (void)state;
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "t", 0), NAV_UP_OK);
    send_range(0, 400, 100, 1);
    /* segment 500.. arrives before 400.. (one lost): refused, nothing moves */
    assert_int_equal(nav_upload_data(&g_u, 500, g_file + 500, 100, 2), NAV_UP_E_GAP);
    assert_int_equal(nav_upload_next(&g_u), 400u);
    assert_int_equal(g_u.state, NAV_UPLOAD_RECEIVING);
    send_range(400, g_size, 150, 3); /* go back to next, other segment size */
    assert_int_equal(nav_upload_end(&g_u, 4), NAV_UP_OK);
    assert_memory_equal(g_rx, g_file, g_size);
}

static void test_duplicate_and_overlap(void **state)
{
    (void)state;
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "t", 0), NAV_UP_OK);
    send_range(0, 300, 100, 1);
    assert_int_equal(nav_upload_data(&g_u, 100, g_file + 100, 100, 2), NAV_UP_DUPLICATE);
    assert_int_equal(nav_upload_next(&g_u), 300u);
    /* overlapping next: only the new tail counts */
    assert_int_equal(nav_upload_data(&g_u, 250, g_file + 250, 100, 2), NAV_UP_OK);
    assert_int_equal(nav_upload_next(&g_u), 350u);
    /* a re-sent segment with other bytes: refused, the upload kept */
    uint8_t bad[100];
    memcpy(bad, g_file + 200, sizeof bad);
    bad[7] ^= 0x40u;
    assert_int_equal(nav_upload_data(&g_u, 200, bad, sizeof bad, 3), NAV_UP_E_CONFLICT);
    assert_int_equal(nav_upload_next(&g_u), 350u);
    send_range(350, g_size, NAV_UPLOAD_SEG_MAX, 4);
    assert_int_equal(nav_upload_end(&g_u, 5), NAV_UP_OK);
    assert_memory_equal(g_rx, g_file, g_size);
}

static void test_oversize(void **state)
{
    (void)state;
    uint8_t big[NAV_UPLOAD_SEG_MAX + 1u] = {0};
    assert_int_equal(nav_upload_start(&g_u, 0, 0, "t", 0), NAV_UP_E_SIZE);
    assert_int_equal(nav_upload_start(&g_u, (uint32_t)sizeof g_rx + 1u, 0, "t", 0), NAV_UP_E_SIZE);
    assert_int_equal(g_u.state, NAV_UPLOAD_IDLE);
    assert_int_equal(nav_upload_data(&g_u, 0, big, 10, 0), NAV_UP_E_STATE);
    assert_int_equal(nav_upload_start(&g_u, 250, 0, "t", 0), NAV_UP_OK);
    assert_int_equal(nav_upload_data(&g_u, 0, big, sizeof big, 0), NAV_UP_E_LENGTH);
    assert_int_equal(nav_upload_data(&g_u, 0, big, 0, 0), NAV_UP_E_LENGTH);
    assert_int_equal(nav_upload_data(&g_u, 0, NULL, 5, 0), NAV_UP_E_LENGTH);
    assert_int_equal(nav_upload_data(&g_u, 0, big, 200, 0), NAV_UP_OK);
    assert_int_equal(nav_upload_data(&g_u, 200, big, 51, 0), NAV_UP_E_OVERRUN); /* 251 > 250 */
    assert_int_equal(nav_upload_next(&g_u), 200u);
    assert_int_equal(nav_upload_end(&g_u, 0), NAV_UP_E_INCOMPLETE);
    assert_int_equal(g_u.state, NAV_UPLOAD_RECEIVING);
}

static void test_names(void **state)
{
    (void)state;
    assert_int_equal(nav_upload_start(&g_u, 10, 0, "", 0), NAV_UP_E_NAME);
    assert_int_equal(nav_upload_start(&g_u, 10, 0, NULL, 0), NAV_UP_E_NAME);
    assert_int_equal(nav_upload_start(&g_u, 10, 0, "../etc/passwd", 0), NAV_UP_E_NAME);
    assert_int_equal(nav_upload_start(&g_u, 10, 0, ".hidden", 0), NAV_UP_E_NAME);
    assert_int_equal(nav_upload_start(&g_u, 10, 0, "a b", 0), NAV_UP_E_NAME);
    assert_int_equal(nav_upload_start(&g_u, 10, 0, "0123456789012345678901234567890123", 0), NAV_UP_E_NAME);
    assert_int_equal(nav_upload_start(&g_u, 10, 0, "0123456789012345678901234567890", 0), NAV_UP_OK); /* 31 */
}

static void test_bad_crc(void **state)
{
    (void)state;
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc() ^ 1u, "t", 0), NAV_UP_OK);
    send_range(0, g_size, NAV_UPLOAD_SEG_MAX, 1);
    assert_int_equal(nav_upload_end(&g_u, 2), NAV_UP_E_CRC);
    assert_int_equal(g_u.state, NAV_UPLOAD_IDLE); /* dropped */
    assert_int_equal(nav_upload_next(&g_u), 0u);
    assert_int_equal(nav_upload_validate(&g_u, &g_table, NULL), NAV_UP_E_STATE);
}

static void test_bad_table(void **state)
{
    (void)state;
    /* a corrupted table whose whole-file CRC is declared right: the link checks pass, the loader refuses */
    static uint8_t bad[MFNS_CALTABLE_MAX_BYTES];
    memcpy(bad, g_file, g_size);
    bad[g_size / 2u] ^= 0x5Au;
    assert_int_equal(nav_upload_start(&g_u, g_size, mfns_crc32(0, bad, g_size), "t", 0), NAV_UP_OK);
    for (uint32_t off = 0; off < g_size; off += NAV_UPLOAD_SEG_MAX) {
        const uint32_t n = g_size - off < NAV_UPLOAD_SEG_MAX ? g_size - off : NAV_UPLOAD_SEG_MAX;
        assert_int_equal(nav_upload_data(&g_u, off, bad + off, n, 1), NAV_UP_OK);
    }
    assert_int_equal(nav_upload_end(&g_u, 2), NAV_UP_OK);
    mfns_caltable_status_t ts = MFNS_CALTABLE_OK;
    assert_int_equal(nav_upload_validate(&g_u, &g_table, &ts), NAV_UP_E_TABLE);
    assert_int_not_equal(ts, MFNS_CALTABLE_OK);
    assert_int_equal(g_u.state, NAV_UPLOAD_IDLE);
}

static void test_abort_timeout_replace(void **state)
{
    (void)state;
    assert_int_equal(nav_upload_abort(&g_u), NAV_UP_E_STATE);
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "a", 0), NAV_UP_OK);
    send_range(0, 400, 200, 10);
    assert_int_equal(nav_upload_abort(&g_u), NAV_UP_OK);
    assert_int_equal(g_u.state, NAV_UPLOAD_IDLE);
    assert_int_equal(g_u.n_abandoned, 1u);
    assert_int_equal(nav_upload_data(&g_u, 400, g_file + 400, 10, 11), NAV_UP_E_STATE);

    /* timeout: 1000 ms after the last command, reported once */
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "a", 100), NAV_UP_OK);
    send_range(0, 200, 200, 500);
    assert_int_equal(nav_upload_tick(&g_u, 1499), NAV_UP_OK);
    assert_int_equal(nav_upload_tick(&g_u, 1500), NAV_UP_E_TIMEOUT);
    assert_int_equal(nav_upload_tick(&g_u, 1501), NAV_UP_OK);
    assert_int_equal(g_u.state, NAV_UPLOAD_IDLE);
    assert_int_equal(g_u.n_abandoned, 2u);

    /* the millisecond clock wrapping is no timeout */
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "a", UINT32_MAX - 10u), NAV_UP_OK);
    assert_int_equal(nav_upload_tick(&g_u, 20u), NAV_UP_OK);

    /* a different START replaces the open upload */
    send_range(0, 200, 200, 21);
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "b", 22), NAV_UP_OK);
    assert_int_equal(nav_upload_next(&g_u), 0u);
    assert_int_equal(g_u.n_abandoned, 3u);
}

static void test_resume(void **state)
{
    (void)state;
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "r", 0), NAV_UP_OK);
    send_range(0, 600, 200, 1);
    /* the ground restarts: the same START resumes; it sends from the reported next */
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "r", 900), NAV_UP_RESUMED);
    assert_int_equal(nav_upload_next(&g_u), 600u);
    assert_int_equal(nav_upload_tick(&g_u, 1800), NAV_UP_OK); /* the START refreshed the timer */
    send_range(nav_upload_next(&g_u), g_size, NAV_UPLOAD_SEG_MAX, 1801);
    assert_int_equal(nav_upload_end(&g_u, 1802), NAV_UP_OK);
    assert_memory_equal(g_rx, g_file, g_size);
}

static void test_store_atomic(void **state)
{
    (void)state;
    char dir[] = "/tmp/mfns_upload_XXXXXX";
    assert_non_null(mkdtemp(dir));
    char path[600];
    assert_int_equal(nav_upload_store(&g_u, dir, path, sizeof path), EINVAL); /* nothing complete */
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "s", 0), NAV_UP_OK);
    send_range(0, g_size, NAV_UPLOAD_SEG_MAX, 1);
    assert_int_equal(nav_upload_end(&g_u, 2), NAV_UP_OK);
    assert_int_equal(nav_upload_validate(&g_u, &g_table, NULL), NAV_UP_OK);
    assert_int_equal(nav_upload_store(&g_u, dir, path, sizeof path), 0);
    assert_int_equal(g_u.state, NAV_UPLOAD_IDLE);
    static uint8_t back[MFNS_CALTABLE_MAX_BYTES + 1u];
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    const size_t n = fread(back, 1, sizeof back, f);
    (void)fclose(f);
    assert_int_equal(n, g_size);
    assert_memory_equal(back, g_file, g_size);
    char tmp[600];
    (void)snprintf(tmp, sizeof tmp, "%s/%s", dir, NAV_UPLOAD_TMP);
    struct stat st;
    assert_int_not_equal(stat(tmp, &st), 0); /* no temp left */
    /* a directory that is not there: the errno, no file */
    assert_int_equal(nav_upload_start(&g_u, g_size, file_crc(), "s", 0), NAV_UP_OK);
    send_range(0, g_size, NAV_UPLOAD_SEG_MAX, 1);
    assert_int_equal(nav_upload_end(&g_u, 2), NAV_UP_OK);
    char gone[600];
    (void)snprintf(gone, sizeof gone, "%s/nope", dir);
    assert_int_equal(nav_upload_store(&g_u, gone, path, sizeof path), ENOENT);
    assert_int_equal(unlink(path) == 0 ? 0 : -1, -1); /* path now names gone/upload.mfnstbl: never written */
    (void)snprintf(path, sizeof path, "%s/%s", dir, NAV_UPLOAD_FILE);
    assert_int_equal(unlink(path), 0);
    assert_int_equal(rmdir(dir), 0);
}

static void test_strerror(void **state)
{
    (void)state;
    for (int s = 0; s < (int)NAV_UP_STATUS_COUNT; s++) {
        assert_string_not_equal(nav_upload_strerror((nav_upload_status_t)s), "unknown upload status");
    }
    assert_string_equal(nav_upload_strerror(NAV_UP_STATUS_COUNT), "unknown upload status");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_in_order_loads, fresh),
        cmocka_unit_test_setup(test_gap_refused_then_resent, fresh),
        cmocka_unit_test_setup(test_duplicate_and_overlap, fresh),
        cmocka_unit_test_setup(test_oversize, fresh),
        cmocka_unit_test_setup(test_names, fresh),
        cmocka_unit_test_setup(test_bad_crc, fresh),
        cmocka_unit_test_setup(test_bad_table, fresh),
        cmocka_unit_test_setup(test_abort_timeout_replace, fresh),
        cmocka_unit_test_setup(test_resume, fresh),
        cmocka_unit_test_setup(test_store_atomic, fresh),
        cmocka_unit_test_setup(test_strerror, fresh),
    };
    return cmocka_run_group_tests(tests, load_default, NULL);
}
