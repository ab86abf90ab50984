/* Unit tests of the ground station's library parts: exact number
 * formatting, argument parsing, the CSV/JSONL writer and an in-process run
 * of ground_run() over a recorded stream with faults. */
#define _DEFAULT_SOURCE /* mkdtemp under -std=c11 */

#include "tests/unit/support/testutil.h"

#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ground/ground.h"
#include "ground/tlm_synth.h"
#include "ground/ground_out.h"

static void test_fixed_point_formatting(void **state)
{
    (void)state;
    char b[32];
    ground_fmt_fixed(b, sizeof b, 1234567, 3);
    assert_string_equal(b, "1234.567");
    ground_fmt_fixed(b, sizeof b, -5, 3);
    assert_string_equal(b, "-0.005");
    ground_fmt_fixed(b, sizeof b, 0, 6);
    assert_string_equal(b, "0.000000");
    ground_fmt_fixed(b, sizeof b, -180000000, 6);
    assert_string_equal(b, "-180.000000");
    ground_fmt_fixed(b, sizeof b, INT32_MIN, 6);
    assert_string_equal(b, "-2147.483648");
    ground_fmt_fixed(b, sizeof b, 4294967295LL, 3);
    assert_string_equal(b, "4294967.295");
    ground_fmt_fixed(b, sizeof b, -42, 0);
    assert_string_equal(b, "-42");
    ground_fmt_utc(b, sizeof b, 0);
    assert_string_equal(b, "1970-01-01T00:00:00.000000Z");
    ground_fmt_utc(b, sizeof b, 1796166000123456LL); /* 2026-12-01T23:00:00.123456 UTC */
    assert_string_equal(b, "2026-12-01T23:00:00.123456Z");
    const tlm_time_t t0 = {12, 0};
    ground_fmt_time(b, sizeof b, &t0);
    assert_string_equal(b, "12.000000");
    const tlm_time_t t1 = {7, 32768};
    ground_fmt_time(b, sizeof b, &t1);
    assert_string_equal(b, "7.500000");
    const tlm_time_t t2 = {7, 65535}; /* 0.9999847 s rounds to 0.999985 */
    ground_fmt_time(b, sizeof b, &t2);
    assert_string_equal(b, "7.999985");
    const tlm_time_t t3 = {UINT32_MAX, 1};
    ground_fmt_time(b, sizeof b, &t3);
    assert_string_equal(b, "4294967295.000015");
}

static void test_argument_parsing(void **state)
{
    (void)state;
    ground_opts_t o;
    FILE *null = fopen("/dev/null", "w");
    assert_non_null(null);
    char *ok[] = {"mfns-ground", "--tty", "/dev/pts/9", "--baud", "115200", "--out", "d", "--max-frames", "10",
                  "--max-seconds", "2.5", "--no-status"};
    assert_int_equal(ground_parse_args(12, ok, &o, null), 0);
    assert_int_equal(o.src, GROUND_SRC_TTY);
    assert_string_equal(o.path, "/dev/pts/9");
    assert_int_equal(o.baud, 115200);
    assert_int_equal(o.max_frames, 10);
    assert_near(o.max_seconds, 2.5, 1e-12);
    assert_int_equal(o.status, 0);
    char *defaults[] = {"mfns-ground", "--port", "/dev/ttyUSB0"};
    assert_int_equal(ground_parse_args(3, defaults, &o, null), 0);
    assert_int_equal(o.src, GROUND_SRC_SERIAL);
    assert_int_equal(o.baud, GROUND_DEFAULT_BAUD);
    assert_string_equal(o.out_dir, "ground-out");
    assert_int_equal(o.status, -1);
    char *none[] = {"mfns-ground"};
    assert_int_equal(ground_parse_args(1, none, &o, null), -1);
    char *two[] = {"mfns-ground", "--file", "a", "--port", "b"};
    assert_int_equal(ground_parse_args(5, two, &o, null), -1);
    char *badbaud[] = {"mfns-ground", "--file", "a", "--baud", "9600.5"};
    assert_int_equal(ground_parse_args(5, badbaud, &o, null), -1);
    char *badsec[] = {"mfns-ground", "--file", "a", "--max-seconds", "-1"};
    assert_int_equal(ground_parse_args(5, badsec, &o, null), -1);
    char *missing[] = {"mfns-ground", "--file"};
    assert_int_equal(ground_parse_args(2, missing, &o, null), -1);
    char *unknown[] = {"mfns-ground", "--file", "a", "--frobnicate", "1"};
    assert_int_equal(ground_parse_args(5, unknown, &o, null), -1);
    fclose(null);
}

static size_t read_file(const char *path, char *buf, size_t cap)
{
    FILE *f = fopen(path, "r");
    assert_non_null(f);
    const size_t n = fread(buf, 1, cap - 1, f);
    buf[n] = '\0';
    fclose(f);
    return n;
}

static void test_ground_run_on_recorded_stream(void **state)
{
    (void)state;
    char dir[] = "/tmp/mfns-ground-XXXXXX";
    assert_non_null(mkdtemp(dir));
    char stream_path[128], out_dir[128], path[160];
    snprintf(stream_path, sizeof stream_path, "%s/s.bin", dir);
    snprintf(out_dir, sizeof out_dir, "%s/out", dir);
    /* 50 cycles of the synthetic stream, with a bit flip in cycle 20's nav frame */
    FILE *f = fopen(stream_path, "wb");
    assert_non_null(f);
    tlm_encoder_t enc;
    tlm_encoder_init(&enc);
    uint32_t frames = 0;
    for (uint32_t i = 0; i < 50; i++) {
        tlm_packet_t pk[GROUND_GEN_MAX_PER_CYCLE];
        const size_t n = ground_gen_cycle(i, pk);
        for (size_t k = 0; k < n; k++) {
            uint8_t fr[TLM_MAX_WIRE];
            size_t len = 0;
            assert_int_equal(tlm_frame_encode(&enc, &pk[k], fr, sizeof fr, &len), TLM_OK);
            if (i == 20 && pk[k].type == TLM_TYPE_NAV) {
                fr[30] = (uint8_t)(fr[30] ^ 0x04u);
                if (fr[30] == 0) {
                    fr[30] = 0x42;
                }
            }
            assert_int_equal(fwrite(fr, 1, len, f), len);
            frames++;
        }
    }
    fclose(f);
    ground_opts_t o;
    memset(&o, 0, sizeof o);
    o.src = GROUND_SRC_FILE;
    o.path = stream_path;
    o.out_dir = out_dir;
    o.status = 0;
    tlm_decoder_stats_t s;
    assert_int_equal(ground_run(&o, &s), 0);
    assert_int_equal(s.frames_ok, frames - 1);
    assert_int_equal(s.crc_errors + s.truncated + s.bad_packets, 1);
    assert_int_equal(s.resyncs, 1);
    assert_int_equal(s.type[TLM_TYPE_NAV].gaps, 1);
    assert_int_equal(s.type[TLM_TYPE_NAV].lost, 1);
    static char text[65536];
    snprintf(path, sizeof path, "%s/nav.csv", out_dir);
    read_file(path, text, sizeof text);
    int lines = 0;
    for (const char *c = text; *c; c++) {
        lines += *c == '\n';
    }
    assert_int_equal(lines, 1 + 49);
    assert_non_null(strstr(text, "\n0.000000,0,0,FIX,0,ACQUIRE,3,1,2,-10.000,15.000,500.000,-0.150000,"));
    assert_null(strstr(text, ",20,FIX,")); /* the damaged cycle is absent, not garbled */
    snprintf(path, sizeof path, "%s/events.jsonl", out_dir);
    read_file(path, text, sizeof text);
    assert_non_null(strstr(text, "\"event\": \"BOOT\""));
    /* the table CRC in hex, as in housekeeping.csv (was signed decimal) */
    assert_non_null(strstr(text, "\"arg1\": \"0x1234abcd\""));
    assert_non_null(strstr(text, "\"ground_utc\": \"20"));
    snprintf(path, sizeof path, "%s/events.csv", out_dir);
    read_file(path, text, sizeof text);
    assert_non_null(strstr(text, ",TABLE_LOADED,2,INFO,0,1,0x1234abcd,"));
    snprintf(path, sizeof path, "%s/housekeeping.csv", out_dir);
    read_file(path, text, sizeof text);
    assert_non_null(strstr(text, ",0x1234abcd,"));
    /* the columns in wire order; a field the dictionary appends comes before ground_utc */
    assert_non_null(strstr(text, "n_degraded,n_cmd_accepted,n_cmd_rejected,cmd_seq_last,cams_enabled,"));
    /* then the packet's UTC (the generator's housekeeping has no time
     * correlation: quality NONE, so correlated at receipt) and the receipt time */
    assert_non_null(strstr(text, ",utc_s,utc_us,time_quality,tc_epoch,tc_arsn_last,n_beacons_biased,frame_period_us,"
                                 "cycle_margin_us,workspace,tc_state,tc_nonce_hi,tc_nonce_lo,tc_report_spi,"
                                 "tc_report_mac0,tc_report_mac1,tc_report_mac2,tc_report_mac3,n_fixlog_errors,"
                                 "n_storage_errors,time_error_us,time_offset_us,utc,time_source,ground_utc\n"));
    assert_non_null(strstr(text, ",NONE,"));
    assert_non_null(strstr(text, ",GROUND_RECEIPT,"));
    snprintf(path, sizeof path, "%s/nav.csv", out_dir);
    read_file(path, text, sizeof text);
    assert_non_null(strstr(text, ",residual_rms_px,q_w,q_x,q_y,q_z,cov_x_x,cov_x_y,cov_x_z,cov_x_rx,cov_x_ry,cov_x_rz,"
                                 "cov_y_y,cov_y_z,cov_y_rx,cov_y_ry,cov_y_rz,cov_z_z,cov_z_rx,cov_z_ry,cov_z_rz,"
                                 "cov_rx_rx,cov_rx_ry,cov_rx_rz,cov_ry_ry,cov_ry_rz,cov_rz_rz,pl_pos_mm,pl_att_deg,utc,"
                                 "time_source,ground_utc\n"));
    /* cycle 0: q = (0.8, 0.6, 0, 0) to 1e-10, cov_x_x = -2.5e-3 (9 digits) */
    assert_non_null(strstr(text, ",0.8000000119,0.6000000238,0.0000000000,0.0000000000,-0.00249999994,"));
    snprintf(path, sizeof path, "%s/stats.json", out_dir);
    read_file(path, text, sizeof text);
    assert_non_null(strstr(text, "\"resyncs\": 1"));
    /* a stream with no valid frame is an error (exit 3), not an empty run */
    f = fopen(stream_path, "wb");
    assert_non_null(f);
    static const uint8_t garbage[] = {0x05, 0x11, 0x22, 0x00, 0x42, 0x42, 0x00, 0x00};
    assert_int_equal(fwrite(garbage, 1, sizeof garbage, f), sizeof garbage);
    fclose(f);
    assert_int_equal(ground_run(&o, &s), GROUND_EXIT_NO_FRAME);
    assert_int_equal(s.frames_ok, 0);
    f = fopen(stream_path, "wb"); /* empty */
    assert_non_null(f);
    fclose(f);
    assert_int_equal(ground_run(&o, NULL), GROUND_EXIT_NO_FRAME);
    /* a missing input is an error, not an empty run */
    o.path = "/nonexistent/stream.bin";
    assert_int_equal(ground_run(&o, NULL), 1);
    /* an output folder that cannot be created */
    o.path = stream_path;
    o.out_dir = "/nonexistent/dir/out";
    assert_int_equal(ground_run(&o, NULL), 1);
    /* clean up */
    static const char *const files[] = {"nav.csv", "nav.jsonl", "camera.csv", "camera.jsonl",
                                        "housekeeping.csv", "housekeeping.jsonl", "events.csv",
                                        "events.jsonl", "stats.json"};
    for (size_t k = 0; k < sizeof files / sizeof files[0]; k++) {
        snprintf(path, sizeof path, "%s/%s", out_dir, files[k]);
        unlink(path);
    }
    rmdir(out_dir);
    unlink(stream_path);
    rmdir(dir);
}

static void test_generator_cycle_contents(void **state)
{
    (void)state;
    tlm_packet_t pk[GROUND_GEN_MAX_PER_CYCLE];
    assert_int_equal(ground_gen_cycle(0, pk), 5);  /* BOOT, nav, 3 cameras */
    assert_int_equal(pk[0].type, TLM_TYPE_EVENT);
    assert_int_equal(pk[0].u.event.code, TLM_EVT_BOOT);
    assert_int_equal(ground_gen_cycle(18, pk), 5); /* nav, 3 cameras, hk */
    assert_int_equal(pk[4].type, TLM_TYPE_HK);
    assert_int_equal(ground_gen_cycle(5, pk), 4);
    assert_int_equal(pk[0].u.nav.att_udeg[2], -175000000);
    assert_int_equal(pk[0].time.coarse_s, 0);
    assert_int_equal(pk[0].time.fine, (5ull * 53763ull * 65536ull) / 1000000ull);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fixed_point_formatting),
        cmocka_unit_test(test_argument_parsing),
        cmocka_unit_test(test_ground_run_on_recorded_stream),
        cmocka_unit_test(test_generator_cycle_contents),
    };
    return cmocka_run_group_tests_name("tlm_ground", tests, NULL, NULL);
}
