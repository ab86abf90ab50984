/* Unit tests of mfns-nav's options table (firmware/app/nav_opts_table.h):
 * its four views agree -- the parser accepts every row, --help and the man
 * page (--help-man) list every option and key, every configuration key
 * stands for an option of a matching type and range -- and the parser
 * behaves as before the table (defaults, ranges and their messages, aliases,
 * the exclusions). */
#define _DEFAULT_SOURCE /* fmemopen under -std=c11 */
#include "tests/unit/support/testutil.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "drivers/camera/camera.h"
#include "firmware/frames/cam_sync.h"
#include "firmware/app/nav_conf.h"
#include "firmware/app/nav_opts.h"
#include "firmware/app/nav_opts_table.h"

typedef struct {
    const char *name;
    char short_name;
    nav_opt_kind_t kind;
    uint32_t lo, hi;
} row_t;

#define ROW(ID, name, sc, kind, meta, lo, hi, wants, set, help) {name, sc, kind, lo, hi},
static const row_t k_rows[] = {NAV_OPTS(ROW, NAV_OPTS_SKIP)};
#undef ROW
#define N_ROWS (sizeof k_rows / sizeof k_rows[0])

static nav_opts_t g_o; /* large (a configuration inside): static */
static char g_out[32768];
static char g_err[1024];

/* nav_opts_parse over argv (NULL-terminated, argv[0] added); its return. */
static int run(const char *const *args)
{
    char *argv[48];
    int argc = 0;
    argv[argc++] = (char *)"mfns-nav";
    for (; args[argc - 1] != NULL && argc < 47; argc++) {
        argv[argc] = (char *)args[argc - 1];
    }
    argv[argc] = NULL;
    memset(g_out, 0, sizeof g_out);
    memset(g_err, 0, sizeof g_err);
    FILE *out = fmemopen(g_out, sizeof g_out - 1u, "w");
    FILE *err = fmemopen(g_err, sizeof g_err - 1u, "w");
    assert_non_null(out);
    assert_non_null(err);
    const int rc = nav_opts_parse(argc, argv, &g_o, out, err);
    assert_int_equal(fclose(out), 0);
    assert_int_equal(fclose(err), 0);
    return rc;
}

static const row_t *row_named(const char *name)
{
    for (size_t i = 0; i < N_ROWS; i++) {
        if (strcmp(k_rows[i].name, name) == 0) {
            return &k_rows[i];
        }
    }
    return NULL;
}

/* s with every '-' as roff's "\-" (how the man page writes an option). */
static void roff_dashes(const char *s, char *buf, size_t n)
{
    size_t j = 0;
    for (; *s != '\0' && j + 3u < n; s++) {
        if (*s == '-') {
            buf[j++] = '\\';
        }
        buf[j++] = *s;
    }
    buf[j] = '\0';
}

static void test_every_option_is_in_help_and_man_page(void **state)
{
    (void)state;
    static char help[sizeof g_out];
    assert_int_equal(run((const char *[]){"--help", NULL}), 1);
    memcpy(help, g_out, sizeof help);
    assert_int_equal(run((const char *[]){"--help-man", NULL}), 1);
    assert_true(strncmp(g_out, ".TH MFNS-NAV 1 ", 15) == 0);
    for (size_t i = 0; i < N_ROWS; i++) {
        char opt[64], line[200], man[160];
        (void)snprintf(opt, sizeof opt, "--%s", k_rows[i].name);
        (void)snprintf(line, sizeof line, "  %s", opt);
        if (k_rows[i].short_name != 0) {
            (void)snprintf(line, sizeof line, "  -%c, %s", k_rows[i].short_name, opt);
        }
        if (strstr(help, line) == NULL) {
            fail_msg("--help lacks the line of %s", opt);
        }
        roff_dashes(opt, man, sizeof man);
        /* the .TP tag: ".B --name", ".BI "--name " META" or ".BR -c ", " --name" */
        char tag_meta[200];
        (void)snprintf(line, sizeof line, "%s %s\n", k_rows[i].short_name != 0 ? "\", \"" : "\n.B", man);
        (void)snprintf(tag_meta, sizeof tag_meta, ".BI \"%s \" ", man);
        if (strstr(g_out, line) == NULL && strstr(g_out, tag_meta) == NULL) {
            fail_msg("the man page lacks %s", opt);
        }
    }
    for (int k = 0; k < (int)NAV_CFG_KEY_COUNT; k++) {
        char line[80];
        const char *name = nav_config_key_name((nav_config_key_t)k);
        (void)snprintf(line, sizeof line, ".B %s\n", name);
        if (strstr(g_out, line) == NULL) {
            fail_msg("the man page lacks the key %s", name);
        }
        (void)snprintf(line, sizeof line, " %s", name);
        if (strstr(help, line) == NULL) {
            fail_msg("--help lacks the key %s", name);
        }
    }
}

static void test_every_key_stands_for_an_option_of_its_type(void **state)
{
    (void)state;
    assert_int_equal(NAV_CFG_KEY_COUNT, 15);
    for (int k = 0; k < (int)NAV_CFG_KEY_COUNT; k++) {
        const nav_config_key_t key = (nav_config_key_t)k;
        const row_t *r = row_named(nav_config_key_option(key));
        if (r == NULL) {
            fail_msg("key %s: no option --%s", nav_config_key_name(key), nav_config_key_option(key));
            return; /* fail_msg does not return; the analyser does not know */
        }
        switch (nav_config_key_type(key)) {
        case NAV_CFG_T_U32:
            assert_int_equal(r->kind, NAV_OPT_U32);
            assert_true(nav_config_key_lo(key) >= r->lo && nav_config_key_hi(key) <= r->hi);
            assert_true(nav_config_key_lo(key) <= nav_config_key_hi(key));
            break;
        case NAV_CFG_T_BOOL:
        case NAV_CFG_T_WORD: /* cameras = v4l2 | libcamera: the two flags */
            assert_int_equal(r->kind, NAV_OPT_FLAG);
            break;
        case NAV_CFG_T_PATH:
        case NAV_CFG_T_TEXT:
            assert_int_equal(r->kind, NAV_OPT_STR);
            break;
        }
    }
    assert_non_null(row_named("libcamera")); /* the other word of `cameras` */
}

static void test_every_option_is_parsed(void **state)
{
    (void)state;
    /* each row, given alone with a valid argument, is accepted by getopt_long
     * (rc != "unknown option") */
    for (size_t i = 0; i < N_ROWS; i++) {
        char opt[64], num[16];
        (void)snprintf(opt, sizeof opt, "--%s", k_rows[i].name);
        (void)snprintf(num, sizeof num, "%u", k_rows[i].lo);
        const char *arg = k_rows[i].kind == NAV_OPT_U32 ? num : "/x";
        if (strcmp(k_rows[i].name, "init-pose") == 0) {
            arg = "0,0,0,0,0,0";
        } else if (strcmp(k_rows[i].name, "fixlog-rotate") == 0) {
            arg = "1,1";
        } else if (strcmp(k_rows[i].name, "config") == 0) {
            continue; /* reads a file: test_nav_conf.c */
        }
        const char *args[] = {opt, k_rows[i].kind == NAV_OPT_FLAG ? NULL : arg, NULL};
        (void)run(args);
        if (strstr(g_err, "unknown or incomplete") != NULL) {
            fail_msg("%s refused: %s", opt, g_err);
        }
    }
}

static void test_defaults_and_a_full_line(void **state)
{
    (void)state;
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", NULL}), 0);
    assert_string_equal(g_o.table_path, "t");
    assert_int_equal(g_o.backend, MFNS_CAM_BACKEND_REPLAY);
    assert_string_equal(g_o.cam_path[2], "d");
    assert_int_equal(g_o.frame_timeout_ms, 200);
    assert_int_equal(g_o.sync_window_us, MFNS_SYNC_WINDOW_US_DEFAULT);
    assert_int_equal(g_o.solver, MFNS_POSE_MODE_ML);
    assert_int_equal(g_o.tlm_kind, NAV_TLM_NONE);
    assert_false(g_o.verbose || g_o.quiet || g_o.mlock || g_o.realtime);
    assert_int_equal(run((const char *[]){"--table", "t", "--v4l2", "--cam-y", "card:b", "--timeout-ms", "60000",
                                          "--sync-window-ms", "7", "--tlm-tty", "/p", "--baud", "1200", "--uplink",
                                          "--tc-key", "/k", "--state-dir", "/s", "--budget-units", "100",
                                          "--nav-filter", "54", "--max-cycles", "4294967294", "--init-pose",
                                          "1,2,3,4,5,6", "--paper", "-v", "-q", "--mlock", "--last-exit", "/e",
                                          "--fixlog", "/f", "--fixlog-rotate", "8,2", "--realtime", NULL}),
                     0);
    assert_int_equal(g_o.backend, MFNS_CAM_BACKEND_V4L2);
    assert_string_equal(g_o.cam_path[1], "card:b");
    assert_int_equal(g_o.frame_timeout_ms, 60000);
    assert_int_equal(g_o.sync_window_us, 7000u);
    assert_int_equal(g_o.tlm_kind, NAV_TLM_PATH);
    assert_string_equal(g_o.tlm_target, "/p");
    assert_int_equal(g_o.baud, 1200u);
    assert_int_equal(g_o.tc_kind, NAV_TC_LINK);
    assert_null(g_o.tc_target);
    assert_string_equal(g_o.tc_key_path, "/k");
    assert_string_equal(g_o.state_dir, "/s");
    assert_int_equal(g_o.budget_units, 100u);
    assert_int_equal(g_o.nav_filter_period_ms, 54u);
    assert_int_equal(g_o.max_cycles, 4294967294u);
    assert_true(g_o.have_init_pose);
    assert_true(g_o.init_pose[5] == 6.0f);
    assert_int_equal(g_o.solver, MFNS_POSE_MODE_PAPER);
    assert_true(g_o.verbose && g_o.quiet && g_o.mlock && g_o.realtime);
    assert_string_equal(g_o.last_exit, "/e");
    assert_string_equal(g_o.fixlog_dir, "/f");
    assert_int_equal(g_o.fixlog_file_kb, 8u);
    assert_int_equal(g_o.fixlog_files, 2u);
}

static void test_errors_keep_their_messages(void **state)
{
    (void)state;
    static const struct {
        const char *opt, *arg, *msg;
    } k_bad[] = {
        {"--timeout-ms", "0", "mfns-nav: --timeout-ms wants 1..60000, got '0'\n"},
        {"--sync-window-ms", "1001", "mfns-nav: --sync-window-ms wants 1..1000, got '1001'\n"},
        {"--baud", "fast", "mfns-nav: --baud wants 1200..4000000, got 'fast'\n"},
        {"--budget-units", "99", "mfns-nav: --budget-units wants 100..1000000, got '99'\n"},
        {"--nav-filter", "0", "mfns-nav: --nav-filter wants a frame period of 1..1000 ms, got '0'\n"},
        {"--max-cycles", "-1", "mfns-nav: --max-cycles wants a positive number, got '-1'\n"},
        {"--init-pose", "1,2", "mfns-nav: --init-pose wants six numbers X,Y,Z,ROLL,PITCH,YAW, got '1,2'\n"},
        {"--fixlog-rotate", "8", "mfns-nav: --fixlog-rotate wants KB,FILES, got '8'\n"},
        {"--fixlog-rotate", "0,2",
         "mfns-nav: --fixlog-rotate wants KB,FILES (1..1048576, 1..1000000), got '0,2'\n"},
    };
    for (size_t i = 0; i < sizeof k_bad / sizeof k_bad[0]; i++) {
        assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", k_bad[i].opt, k_bad[i].arg, NULL}),
                         -1);
        assert_string_equal(g_err, k_bad[i].msg);
    }
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--bogus", NULL}), -1);
    assert_string_equal(g_err, "mfns-nav: unknown or incomplete option '--bogus' (see --help)\n");
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "x", NULL}), -1);
    assert_string_equal(g_err, "mfns-nav: unexpected argument 'x' (see --help)\n");
    assert_int_equal(run((const char *[]){"--replay", "d", NULL}), -1);
    assert_string_equal(g_err, "mfns-nav: --table FILE (or the configuration's 'table') is required (see --help)\n");
    assert_int_equal(run((const char *[]){"--table", "t", NULL}), -1);
    assert_non_null(strstr(g_err, "choose the cameras"));
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--file", "a", "--tlm-tty", "b", NULL}),
                     -1);
    assert_string_equal(g_err, "mfns-nav: give one telemetry output (--serial, --tty or --file)\n");
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--tc-tty", "a", "--uplink", NULL}), -1);
    assert_string_equal(g_err, "mfns-nav: give one telecommand input (--tc-tty, --tc-file or --uplink)\n");
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--tc-file", "a", NULL}), -1);
    assert_non_null(strstr(g_err, "a command input needs --tc-key FILE --state-dir DIR"));
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--uplink", "--tc-insecure", NULL}), -1);
    assert_non_null(strstr(g_err, "--uplink reads commands from the telemetry link"));
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--tc-key", "k", "--tc-insecure", NULL}),
                     -1);
    assert_string_equal(g_err, "mfns-nav: --tc-key and --tc-insecure exclude each other\n");
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--tc-key", "k", NULL}), -1);
    assert_non_null(strstr(g_err, "--tc-key needs --state-dir DIR"));
    assert_int_equal(run((const char *[]){"--table", "t", "--replay", "d", "--cam-x", "c", NULL}), -1);
    assert_string_equal(g_err, "mfns-nav: --cam-x/y/z do not apply to --replay\n");
    assert_int_equal(run((const char *[]){"--version", NULL}), 1);
    assert_true(strncmp(g_out, "mfns-nav ", 9) == 0);
    assert_int_equal(run((const char *[]){"-h", NULL}), 1);
    assert_true(strncmp(g_out, "usage: mfns-nav", 15) == 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_option_is_in_help_and_man_page),
        cmocka_unit_test(test_every_key_stands_for_an_option_of_its_type),
        cmocka_unit_test(test_every_option_is_parsed),
        cmocka_unit_test(test_defaults_and_a_full_line),
        cmocka_unit_test(test_errors_keep_their_messages),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
