/* Unit tests of firmware/app/nav_fixlog: the fix record's packets, the log
 * (whole records, readable back with the link's decoder), rotation by size
 * keeping N files, and a full ring that drops and counts instead of waiting. */
#define _POSIX_C_SOURCE 200809L
#include "tests/unit/support/testutil.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "firmware/app/nav_fixlog.h"
#include "tests/unit/support/pose_testlib.h"
#include "firmware/tlm/tlm_decoder.h"

static nav_fixlog_t log_; /* 270 kB: static storage, as the app keeps it */
static mfns_nav_output_t out;
static mfns_obs_frame_t obs;
static mfns_beacon_map_t map;
static mfns_rig_t rig; /* zero: no re-association in these tests (gate 0) */
static tlm_packet_t pk[NAV_FIXLOG_MAX_ASSOC];

/* A DEGRADED fix of 5 associations (one gated out), beacon ids 100 + index. */
static void a_fix(void)
{
    memset(&out, 0, sizeof out);
    memset(&obs, 0, sizeof obs);
    memset(&map, 0, sizeof map);
    map.count = 10;
    for (uint16_t b = 0; b < map.count; b++) {
        map.beacon[b].id = (uint16_t)(100u + b);
    }
    out.sol.status = MFNS_POSE_DEGRADED;
    obs.count[0] = 3;
    obs.count[2] = 3;
    for (int i = 0; i < 3; i++) {
        for (int k = 0; k < 3; k += 2) {
            obs.obs[k][i].u = 100.0f * (float)(i + 1) + (float)k;
            obs.obs[k][i].v = 50.0f * (float)(i + 1);
            obs.obs[k][i].cov_px2[0] = 1e-4f;
            obs.obs[k][i].cov_px2[2] = 2e-4f;
            out.sol.assoc.beacon[k][i] = (int16_t)(i + 3 * k / 2);
            out.sol.inlier[k][i] = 1U;
        }
    }
    out.sol.inlier[2][1] = 0U; /* gated out: not a recorded association */
}

static void nav_packet(tlm_packet_t *p, uint32_t cycle)
{
    memset(p, 0, sizeof *p);
    p->type = TLM_TYPE_NAV;
    p->u.nav.cycle = cycle;
    p->u.nav.status = TLM_NAV_DEGRADED;
    p->u.nav.q_q30[0] = 1 << 30;
}

static void test_packets_of_a_fix(void **state)
{
    (void)state;
    a_fix();
    const unsigned n = nav_fixlog_packets(&out, &obs, &rig, &map, 0.0f, 7u, 1000u, pk, NAV_FIXLOG_MAX_ASSOC);
    assert_int_equal(n, 5);
    for (unsigned i = 0; i < n; i++) {
        assert_int_equal(pk[i].type, TLM_TYPE_FIXOBS);
        assert_int_equal(pk[i].u.fixobs.cycle, 7);
        assert_int_equal(pk[i].u.fixobs.index, i);
        assert_int_equal(pk[i].u.fixobs.count, 5);
        assert_true(tlm_payload_valid(&pk[i]));
    }
    assert_int_equal(pk[0].u.fixobs.beacon_id, 100);
    assert_int_equal(pk[3].u.fixobs.camera, 2);
    assert_int_equal(pk[3].u.fixobs.beacon_id, 103);
    assert_int_equal(pk[4].u.fixobs.beacon_id, 105); /* [2][1] (104) was gated out */
    assert_true(pk[4].u.fixobs.uv_px[0] == 302.0f);
    /* no fix, no record; the cap holds */
    assert_int_equal(nav_fixlog_packets(&out, &obs, &rig, &map, 0.0f, 7u, 1000u, pk, 2u), 2);
    out.sol.status = MFNS_POSE_NO_FIX;
    assert_int_equal(nav_fixlog_packets(&out, &obs, &rig, &map, 0.0f, 7u, 1000u, pk, NAV_FIXLOG_MAX_ASSOC), 0);
}

/* A blob the fix did not use is recorded for the survey with the beacon
 * predicted nearest within the gate (used 0); without a gate it is not. */
static void test_unused_blob_reassociated_within_the_gate(void **state)
{
    (void)state;
    mfns_rng_t rng;
    mfns_rng_seed(&rng, 5);
    static mfns_rig_t prig;
    static mfns_beacon_map_t pmap;
    prig = pt_paper_rig();
    const pt_dpose_t truth = pt_random_pose(&rng, 100);
    const int per_cam[3] = {4, 4, 4};
    pmap = pt_dense_map(&prig, &truth, per_cam, 1500, 3000, &rng);
    mfns_pose_assoc_t assoc;
    const int n_obs = pt_make_frame(&prig, &pmap, &truth, 0.02, &rng, &obs, &assoc);
    assert_true(n_obs >= 10);
    memset(&out, 0, sizeof out);
    out.sol.status = MFNS_POSE_OK;
    out.sol.pose = pt_to_float(&truth);
    out.sol.assoc = assoc;
    for (int k = 0; k < 3; k++) {
        for (int i = 0; i < obs.count[k]; i++) {
            out.sol.inlier[k][i] = 1U;
        }
    }
    const int16_t held = out.sol.assoc.beacon[1][0];
    out.sol.assoc.beacon[1][0] = MFNS_POSE_NO_BEACON; /* held out by integrity, say */
    out.sol.inlier[1][0] = 0U;
    unsigned n = nav_fixlog_packets(&out, &obs, &prig, &pmap, 10.0f, 3u, 0u, pk, NAV_FIXLOG_MAX_ASSOC);
    assert_int_equal(n, (unsigned)n_obs);
    unsigned unused = 0;
    for (unsigned i = 0; i < n; i++) {
        if (pk[i].u.fixobs.used == 0U) {
            unused++;
            assert_int_equal(pk[i].u.fixobs.camera, 1);
            assert_int_equal(pk[i].u.fixobs.beacon_id, pmap.beacon[held].id);
        }
    }
    assert_int_equal(unused, 1);
    n = nav_fixlog_packets(&out, &obs, &prig, &pmap, 0.0f, 3u, 0u, pk, NAV_FIXLOG_MAX_ASSOC);
    assert_int_equal(n, (unsigned)n_obs - 1u);
}

static size_t file_size(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        return 0;
    }
    (void)fseek(f, 0, SEEK_END);
    const long n = ftell(f);
    (void)fclose(f);
    return n > 0 ? (size_t)n : 0;
}

static void test_log_rotates_and_reads_back(void **state)
{
    (void)state;
    char dir[] = "/tmp/mfns_fixlog_XXXXXX";
    assert_non_null(mkdtemp(dir));
    a_fix();
    const unsigned n = nav_fixlog_packets(&out, &obs, &rig, &map, 0.0f, 0u, 0u, pk, NAV_FIXLOG_MAX_ASSOC);
    /* files of ~2 records, 3 kept */
    assert_int_equal(nav_fixlog_open(&log_, dir, 600u, 3u), 0);
    tlm_packet_t nav;
    for (uint32_t c = 0; c < 20; c++) {
        nav_packet(&nav, c);
        for (unsigned i = 0; i < n; i++) {
            pk[i].u.fixobs.cycle = c;
        }
        assert_true(nav_fixlog_record(&log_, &nav, pk, n));
        /* Let the writer take each record before the next (files then hold ~2
         * each): wait until it has, not a fixed time, which a loaded machine
         * can overrun. Bounded: 500 x 2 ms. */
        const struct timespec wait = {0, 2000000L};
        for (int t = 0; t < 500 && atomic_load(&log_.tail) != atomic_load(&log_.head); t++) {
            (void)nanosleep(&wait, NULL);
        }
        assert_int_equal(atomic_load(&log_.tail), atomic_load(&log_.head));
    }
    nav_fixlog_close(&log_);
    assert_int_equal(atomic_load(&log_.records), 20);
    assert_int_equal(atomic_load(&log_.dropped_records), 0);
    assert_int_equal(atomic_load(&log_.write_errors), 0);
    /* the last files remain, the first ones were rotated out */
    char path[600];
    const uint32_t last = log_.file_no;
    assert_true(last >= 5u);
    snprintf(path, sizeof path, "%s/fixlog_%06u.tlm", dir, last - 3u);
    assert_int_equal(file_size(path), 0);
    size_t packets = 0;
    for (uint32_t f = last - 2u; f <= last; f++) {
        snprintf(path, sizeof path, "%s/fixlog_%06u.tlm", dir, f);
        FILE *fp = fopen(path, "rb");
        assert_non_null(fp);
        static uint8_t buf[8192];
        const size_t len = fread(buf, 1, sizeof buf, fp);
        (void)fclose(fp);
        assert_true(len > 0);
        tlm_decoder_t dec;
        tlm_decoder_init(&dec);
        for (size_t i = 0; i < len; i++) {
            tlm_packet_t p;
            if (tlm_decoder_push(&dec, buf[i], &p) == 1) {
                packets++;
            }
        }
        assert_int_equal(dec.stats.crc_errors, 0);
        unlink(path);
    }
    assert_true(packets > 0 && packets % (n + 1u) == 0); /* whole records only */
    rmdir(dir);
}

static void test_full_ring_drops_and_counts(void **state)
{
    (void)state;
    a_fix();
    const unsigned n = nav_fixlog_packets(&out, &obs, &rig, &map, 0.0f, 0u, 0u, pk, NAV_FIXLOG_MAX_ASSOC);
    assert_true(n > 0u);
    /* The ring alone, without its writer (white box: a log marked open whose
     * thread never started, so nothing empties it): whether a record is
     * dropped must not depend on how fast the writer runs (under qemu-user
     * it kept up with a tight loop of 2000). */
    memset(&log_, 0, sizeof log_);
    log_.open = true;
    tlm_packet_t nav;
    nav_packet(&nav, 1u);
    unsigned kept = 0, dropped = 0;
    for (unsigned i = 0; i < 2000u; i++) {
        if (nav_fixlog_record(&log_, &nav, pk, n)) {
            assert_int_equal(dropped, 0); /* once full it stays full: no record after a drop */
            kept++;
        } else {
            dropped++;
        }
    }
    const size_t used = atomic_load(&log_.head) - atomic_load(&log_.tail);
    assert_true(kept > 0u && dropped > 0u);
    assert_true(used <= NAV_FIXLOG_RING_BYTES);
    assert_true(used > NAV_FIXLOG_RING_BYTES - NAV_FIXLOG_MAX_RECORD); /* full to within one record */
    assert_int_equal(used % kept, 0);                                   /* whole records only */
    assert_int_equal(atomic_load(&log_.records), kept);
    assert_int_equal(atomic_load(&log_.dropped_records), dropped);
    assert_int_equal(kept + dropped, 2000);
    log_.open = false; /* never started: nothing to join */
    /* closed: recording is refused, never blocks */
    assert_false(nav_fixlog_record(&log_, &nav, pk, n));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_packets_of_a_fix),
        cmocka_unit_test(test_unused_blob_reassociated_within_the_gate),
        cmocka_unit_test(test_log_rotates_and_reads_back),
        cmocka_unit_test(test_full_ring_drops_and_counts),
    };
    return cmocka_run_group_tests_name("nav_fixlog", tests, NULL, NULL);
}
