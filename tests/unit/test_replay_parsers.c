/* Unit tests of the replay readers' pure parsers (drivers/camera/replay_*.h):
 * frames.csv rows validated once and attributed to one camera, and the
 * scenario.json check (top-level keys only, integer version, strict JSON). */
#include "tests/unit/support/testutil.h"

#include <string.h>

#include "drivers/camera/replay_index.h"
#include "drivers/camera/replay_pgm.h"
#include "drivers/camera/replay_scenario.h"

#define HDR "frame,t_s,camera,file,exposure_us,gain_db\n"

static uint32_t parse(const char *csv, mfns_replay_row_t *rows, uint32_t cap, char *text, size_t text_cap)
{
    const size_t n = strlen(csv);
    assert_true(n < text_cap);
    memcpy(text, csv, n + 1);
    uint32_t nr = 0;
    char why[192];
    assert_true(mfns_replay_index_parse(text, n, 200, rows, cap, &nr, why, sizeof why));
    return nr;
}

static void test_bad_rows_are_attributed_to_one_camera(void **state)
{
    (void)state;
    static char text[2048];
    mfns_replay_row_t rows[16];
    const uint32_t n = parse(HDR "0,0.0,x,cam_x/0.pgm,5,0\n"
                                 "0,0.0,y,cam_y/0.pgm,5\n"        /* 5 fields: still camera y's */
                                 "0,0.0,w,cam_z/0.pgm,5,0\n"      /* nobody's */
                                 "0,0.0,x,cam_x/0.pgm,5,0\n"      /* duplicate of x's frame 0 */
                                 "1,0.05,x,../up.pgm,5,0\n"       /* escapes the folder */
                                 "1,0.05,y,cam_y/1.pgm,-5,0\n"    /* negative exposure */
                                 "1,0.05,z,cam_z/1.pgm,5,0\r\n"   /* CRLF is fine */
                                 "2,inf,z,cam_z/2.pgm,5,0\n"
                                 "2,0.10,z,cam_z/2.pgm,5,0x10\n"
                                 "\n",
                             rows, 16, text, sizeof text);
    assert_int_equal(n, 10);
    const struct {
        char cam;
        uint8_t status;
    } want[10] = {{'x', MFNS_ROW_OK},    {'y', MFNS_ROW_FIELDS}, {'\0', MFNS_ROW_CAMERA}, {'x', MFNS_ROW_ORDER},
                  {'x', MFNS_ROW_FILE},  {'y', MFNS_ROW_EXPOSURE}, {'z', MFNS_ROW_OK},    {'z', MFNS_ROW_TIME},
                  {'z', MFNS_ROW_GAIN},  {'\0', MFNS_ROW_FIELDS}};
    for (uint32_t i = 0; i < n; i++) {
        assert_int_equal(rows[i].camera, want[i].cam);
        assert_int_equal(rows[i].status, want[i].status);
        assert_int_equal(rows[i].line, i + 2u);
    }
    assert_string_equal(rows[6].file, "cam_z/1.pgm");
    char msg[192];
    mfns_replay_row_message(&rows[3], msg, sizeof msg);
    assert_non_null(strstr(msg, "line 5: camera x frame 0 at 0.000000 s does not follow frame 0"));
    mfns_replay_row_message(&rows[2], msg, sizeof msg);
    assert_non_null(strstr(msg, "camera 'w' is not x, y or z"));
}

static void test_nul_and_long_rows(void **state)
{
    (void)state;
    static char text[2048];
    static const char csv[] = HDR "0,0.0,x,cam\0x.pgm,5,0\n1,0.1,x,cam_x/1.pgm,5,0\n";
    const size_t n = sizeof csv - 1;
    memcpy(text, csv, n);
    mfns_replay_row_t rows[4];
    uint32_t nr = 0;
    char why[192];
    assert_true(mfns_replay_index_parse(text, n, 200, rows, 4, &nr, why, sizeof why));
    assert_int_equal(nr, 2);
    assert_int_equal(rows[0].status, MFNS_ROW_NUL);
    assert_int_equal(rows[1].status, MFNS_ROW_OK);
    char longrow[700];
    memset(longrow, 'a', sizeof longrow);
    memcpy(longrow, HDR, strlen(HDR));
    longrow[sizeof longrow - 1] = '\0';
    nr = parse(longrow, rows, 4, text, sizeof text);
    assert_int_equal(nr, 1);
    assert_int_equal(rows[0].status, MFNS_ROW_LONG);
    /* a wrong header or too many rows refuse the file */
    memcpy(text, "frame,t\n", 9);
    assert_false(mfns_replay_index_parse(text, 8, 200, rows, 4, &nr, why, sizeof why));
    assert_non_null(strstr(why, "header"));
    const char *many = HDR "0,0,x,a,1,0\n1,0,x,a,1,0\n2,0,x,a,1,0\n";
    memcpy(text, many, strlen(many) + 1);
    assert_false(mfns_replay_index_parse(text, strlen(many), 200, rows, 2, &nr, why, sizeof why));
    assert_true(mfns_replay_count_rows(many, strlen(many)) >= 4);
}

static bool scen(const char *json, const char *needle)
{
    char why[192] = "";
    const bool ok = mfns_replay_scenario_check(json, strlen(json), why, sizeof why);
    if (!ok && needle && !strstr(why, needle)) {
        print_error("\"%s\": message \"%s\" lacks \"%s\"\n", json, why, needle);
        return true; /* reported as a mismatch below */
    }
    return ok;
}

static void test_scenario_check(void **state)
{
    (void)state;
    assert_true(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1}", NULL));
    assert_true(scen(" {\"version\":1,\"x\":[1,-2.5e3,{\"version\":9}],\"format\":\"mfns-nav-frames\"}\n", NULL));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1.5}", "not a whole number"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1e0}", "not a whole number"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": \"1\"}", "not a number"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 2}", "version 2 is newer"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 99999999999999999999}", "newer"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 0}", "not a positive"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": -1}", "not a positive"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"m\": {\"version\": 1}}", "missing"));
    assert_false(scen("{\"m\": {\"format\": \"mfns-nav-frames\"}, \"version\": 1}", "format"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1, \"version\": 1}", "duplicated"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1,}", "expected a key"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1, \"a\": [1,]}", "unexpected"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1} x", "after the top-level"));
    assert_false(scen("[1]", "not a JSON object"));
    assert_false(scen("{\"format\": \"mfns-nav-frames\", \"version\": 1", "end of text"));
    assert_false(scen("{\"format\": \"mfns-nav-\x01frames\", \"version\": 1}", "control character"));
    static char deep[300];
    memset(deep, '[', sizeof deep - 1);
    memcpy(deep, "{\"a\":", 5);
    deep[sizeof deep - 1] = '\0';
    assert_false(scen(deep, "nested deeper"));
}

static void test_pgm_header(void **state)
{
    (void)state;
    mfns_pgm_header_t hd;
    char why[128];
    static const uint8_t ok[] = "P5\n4 2\n1023\n";
    assert_true(mfns_pgm_parse_header(ok, sizeof ok - 1, 8192, &hd, why, sizeof why));
    assert_int_equal(hd.width, 4);
    assert_int_equal(hd.maxval, 1023);
    assert_int_equal(hd.data_off, sizeof ok - 1);
    assert_int_equal(mfns_pgm_pixel_bytes(&hd), 16);
    static const uint8_t big[] = "P5\n9000 2\n255\n";
    assert_false(mfns_pgm_parse_header(big, sizeof big - 1, 8192, &hd, why, sizeof why));
    assert_non_null(strstr(why, "outside"));
    uint8_t px[4] = {0x03, 0xff, 0x04, 0x00};
    size_t bad = 0;
    assert_false(mfns_pgm_to_native(px, 4, 1023, &bad));
    assert_int_equal(bad, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_rows_are_attributed_to_one_camera),
        cmocka_unit_test(test_nul_and_long_rows),
        cmocka_unit_test(test_scenario_check),
        cmocka_unit_test(test_pgm_header),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
