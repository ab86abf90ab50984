/* nav_opts.c -- see nav_opts.h. */
#define _DEFAULT_SOURCE /* getopt_long under -std=c11 */

#include "firmware/app/nav_opts.h"

#include <errno.h>
#include <getopt.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "firmware/frames/cam_sync.h"
#include "firmware/app/nav_opts_table.h"
#include "mfns_version.h"

#ifndef MFNS_BOARD_NAME
#define MFNS_BOARD_NAME "unknown"
#endif
#ifndef MFNS_BOARD_BAUD
#define MFNS_BOARD_BAUD 115200
#endif
#ifndef MFNS_BOARD_CAM_X
#define MFNS_BOARD_CAM_X "/dev/video0"
#define MFNS_BOARD_CAM_Y "/dev/video1"
#define MFNS_BOARD_CAM_Z "/dev/video2"
#endif

static bool parse_u32(const char *s, uint32_t lo, uint32_t hi, uint32_t *v)
{
    char *end = NULL;
    errno = 0;
    const unsigned long x = strtoul(s, &end, 10);
    if (errno != 0 || end == s || *end != '\0' || s[0] == '-' || x < lo || x > hi) {
        return false;
    }
    *v = (uint32_t)x;
    return true;
}

static bool parse_pose(const char *s, float v[6])
{
    const char *p = s;
    for (int i = 0; i < 6; i++) {
        char *end = NULL;
        errno = 0;
        const double x = strtod(p, &end);
        if (errno != 0 || end == p || !(x > -1e6 && x < 1e6)) {
            return false;
        }
        v[i] = (float)x;
        if (i < 5) {
            if (*end != ',') {
                return false;
            }
            p = end + 1;
        } else if (*end != '\0') {
            return false;
        }
    }
    return true;
}

/* --config FILE or --config=FILE anywhere on the line (the last one wins,
 * as getopt would); NULL when absent. A --config without its FILE is left to
 * getopt's error. */
static const char *find_config(int argc, char **argv)
{
    static const char eq[] = "--config=";
    const char *path = NULL;
    for (int i = 1; i < argc; i++) {
        if (strcmp(argv[i], "--") == 0) {
            break;
        }
        if (strcmp(argv[i], "--config") == 0 && i + 1 < argc) {
            path = argv[++i];
        } else if (strncmp(argv[i], eq, sizeof eq - 1u) == 0) {
            path = argv[i] + sizeof eq - 1u;
        }
    }
    return path;
}

/* Where each setting came from, so the line replaces the file's (never
 * "give one telemetry output" for a --tty over the file's uart). */
typedef struct {
    bool tlm, tc, key, insecure;
    const char *cam[MFNS_NUM_CAMERAS];
} from_file_t;

/* The file's keys into o (defaults for the command line). 0, or -1 with the message. */
static int apply_config(nav_opts_t *o, from_file_t *ff, FILE *err)
{
    const nav_config_t *c = &o->cfg;
    const char *p = o->config_path;
    if (c->set[NAV_CFG_UART] && c->set[NAV_CFG_TTY]) {
        fprintf(err, "mfns-nav: %s:%u: key 'tty': excludes 'uart' (line %u): give one telemetry output\n", p,
                c->line[NAV_CFG_TTY], c->line[NAV_CFG_UART]);
        return -1;
    }
    if (c->set[NAV_CFG_TC_KEY] && c->set[NAV_CFG_TC_INSECURE] && c->number[NAV_CFG_TC_INSECURE] != 0u) {
        fprintf(err, "mfns-nav: %s:%u: key 'tc_insecure': excludes 'tc_key' (line %u)\n", p,
                c->line[NAV_CFG_TC_INSECURE], c->line[NAV_CFG_TC_KEY]);
        return -1;
    }
    if (c->set[NAV_CFG_CAMERAS]) {
        const bool v4l2 = strcmp(c->value[NAV_CFG_CAMERAS], "v4l2") == 0;
        o->backend = v4l2 ? MFNS_CAM_BACKEND_V4L2 : MFNS_CAM_BACKEND_LIBCAMERA;
        o->cam_path[0] = v4l2 ? MFNS_BOARD_CAM_X : "";
        o->cam_path[1] = v4l2 ? MFNS_BOARD_CAM_Y : "";
        o->cam_path[2] = v4l2 ? MFNS_BOARD_CAM_Z : "";
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        const nav_config_key_t key = (nav_config_key_t)(NAV_CFG_CAM_X + k);
        ff->cam[k] = c->set[key] ? c->value[key] : NULL;
    }
    if (c->set[NAV_CFG_UART] || c->set[NAV_CFG_TTY]) {
        o->tlm_kind = c->set[NAV_CFG_UART] ? NAV_TLM_SERIAL : NAV_TLM_PATH;
        o->tlm_target = c->set[NAV_CFG_UART] ? c->value[NAV_CFG_UART] : c->value[NAV_CFG_TTY];
        ff->tlm = true;
    }
    if (c->set[NAV_CFG_BAUD]) {
        o->baud = c->number[NAV_CFG_BAUD];
    }
    if (c->set[NAV_CFG_UPLINK] && c->number[NAV_CFG_UPLINK] != 0u) {
        o->tc_kind = NAV_TC_LINK;
        ff->tc = true;
    }
    if (c->set[NAV_CFG_TC_KEY]) {
        o->tc_key_path = c->value[NAV_CFG_TC_KEY];
        ff->key = true;
    }
    if (c->set[NAV_CFG_TC_INSECURE]) {
        o->tc_insecure = c->number[NAV_CFG_TC_INSECURE] != 0u;
        o->tc_insecure_from_config = o->tc_insecure;
        ff->insecure = true;
    }
    if (c->set[NAV_CFG_TABLE]) {
        o->table_path = c->value[NAV_CFG_TABLE];
    }
    if (c->set[NAV_CFG_STATE_DIR]) {
        o->state_dir = c->value[NAV_CFG_STATE_DIR];
    }
    if (c->set[NAV_CFG_TIMEOUT_MS]) {
        if (c->number[NAV_CFG_TIMEOUT_MS] > (uint32_t)MFNS_CAM_MAX_TIMEOUT_MS) {
            fprintf(err, "mfns-nav: %s:%u: key 'timeout_ms': wants 1..%d\n", p, c->line[NAV_CFG_TIMEOUT_MS],
                    MFNS_CAM_MAX_TIMEOUT_MS);
            return -1;
        }
        o->frame_timeout_ms = (int)c->number[NAV_CFG_TIMEOUT_MS];
    }
    if (c->set[NAV_CFG_MLOCK]) {
        o->mlock = c->number[NAV_CFG_MLOCK] != 0u;
    }
    if (c->set[NAV_CFG_BUDGET_UNITS]) {
        o->budget_units = c->number[NAV_CFG_BUDGET_UNITS];
    }
    return 0;
}

/* ---- the options' table (nav_opts_table.h) and its typed setters ---- */

#define NAV_OPT_ENUM(ID, name, sc, kind, meta, lo, hi, wants, set, help) NAV_OPT_##ID,
typedef enum { NAV_OPTS(NAV_OPT_ENUM, NAV_OPTS_SKIP) NAV_OPT_COUNT } nav_opt_id_t;
#undef NAV_OPT_ENUM

/* What one option's setter sees besides o: which option, the file's settings
 * it may replace, the cameras named on the line, the help stream. */
typedef struct {
    nav_opt_id_t id;
    from_file_t ff;
    const char *cam_override[MFNS_NUM_CAMERAS];
    FILE *out;
} parse_state_t;

/* 0 ok, 1 printed (--help, --version: exit 0), -1 error printed on err.
 * num: the checked number of a NAV_OPT_U32 option. */
typedef int (*nav_opt_set_fn)(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err);

typedef struct {
    const char *name;
    char short_name;
    nav_opt_kind_t kind;
    const char *meta;
    uint32_t lo, hi;
    const char *wants;
    nav_opt_set_fn set;
    const char *help;
} nav_opt_row_t;

static int set_config(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)o, (void)st, (void)arg, (void)num, (void)err;
    return 0; /* read before the options (find_config) */
}

static int set_table(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)num, (void)err;
    o->table_path = arg;
    return 0;
}

static int set_replay(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)num, (void)err;
    o->backend = MFNS_CAM_BACKEND_REPLAY;
    o->cam_path[0] = o->cam_path[1] = o->cam_path[2] = arg;
    st->ff.cam[0] = st->ff.cam[1] = st->ff.cam[2] = NULL; /* the file's cameras are not a replay's */
    return 0;
}

static int set_realtime(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)num, (void)err;
    o->realtime = true;
    return 0;
}

static int set_v4l2(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)num, (void)err;
    o->backend = MFNS_CAM_BACKEND_V4L2;
    o->cam_path[0] = MFNS_BOARD_CAM_X;
    o->cam_path[1] = MFNS_BOARD_CAM_Y;
    o->cam_path[2] = MFNS_BOARD_CAM_Z;
    return 0;
}

static int set_libcamera(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)num, (void)err;
    o->backend = MFNS_CAM_BACKEND_LIBCAMERA;
    o->cam_path[0] = o->cam_path[1] = o->cam_path[2] = "";
    return 0;
}

static int set_cam(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)o, (void)num, (void)err;
    _Static_assert(NAV_OPT_CAM_Y == NAV_OPT_CAM_X + 1 && NAV_OPT_CAM_Z == NAV_OPT_CAM_X + 2, "x, y, z in order");
    st->cam_override[st->id - NAV_OPT_CAM_X] = arg;
    return 0;
}

static int set_timeout(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)err;
    o->frame_timeout_ms = (int)num; /* <= MFNS_CAM_MAX_TIMEOUT_MS */
    return 0;
}

static int set_sync_window(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)err;
    o->sync_window_us = num * 1000u;
    return 0;
}

/* --serial/--tty/--file (and their older spellings): one telemetry output;
 * the line's replaces the file's. */
static int set_tlm(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)num;
    if (st->ff.tlm) {
        o->tlm_kind = NAV_TLM_NONE;
        st->ff.tlm = false;
    }
    if (o->tlm_kind != NAV_TLM_NONE) {
        fprintf(err, "mfns-nav: give one telemetry output (--serial, --tty or --file)\n");
        return -1;
    }
    const bool serial = st->id == NAV_OPT_SERIAL || st->id == NAV_OPT_TLM_SERIAL;
    const bool tty = st->id == NAV_OPT_TTY || st->id == NAV_OPT_TLM_TTY;
    o->tlm_kind = serial ? NAV_TLM_SERIAL : (tty ? NAV_TLM_PATH : NAV_TLM_FILE);
    o->tlm_target = arg;
    return 0;
}

/* --tc-tty/--tc-file/--uplink: one telecommand input; the line's replaces the file's. */
static int set_tc(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)num;
    if (st->ff.tc) {
        o->tc_kind = NAV_TC_NONE;
        st->ff.tc = false;
    }
    if (o->tc_kind != NAV_TC_NONE) {
        fprintf(err, "mfns-nav: give one telecommand input (--tc-tty, --tc-file or --uplink)\n");
        return -1;
    }
    o->tc_kind = st->id == NAV_OPT_TC_TTY ? NAV_TC_PATH : (st->id == NAV_OPT_TC_FILE ? NAV_TC_FILE : NAV_TC_LINK);
    o->tc_target = st->id == NAV_OPT_UPLINK ? NULL : arg;
    return 0;
}

static int set_tc_key(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)num, (void)err;
    o->tc_key_path = arg;
    if (st->ff.insecure) { /* the line's key replaces the file's tc_insecure */
        o->tc_insecure = false;
        o->tc_insecure_from_config = false;
    }
    return 0;
}

static int set_state_dir(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)num, (void)err;
    o->state_dir = arg;
    return 0;
}

static int set_tc_insecure(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)arg, (void)num, (void)err;
    o->tc_insecure = true;
    o->tc_insecure_from_config = false;
    if (st->ff.key) { /* ... and replaces the file's tc_key */
        o->tc_key_path = NULL;
    }
    return 0;
}

static int set_budget(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)err;
    o->budget_units = num;
    return 0;
}

static int set_nav_filter(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)err;
    o->nav_filter_period_ms = num;
    return 0;
}

static int set_baud(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)err;
    o->baud = num;
    return 0;
}

static int set_max_cycles(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)err;
    o->max_cycles = num;
    return 0;
}

static int set_init_pose(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)num;
    if (!parse_pose(arg, o->init_pose)) {
        fprintf(err, "mfns-nav: --init-pose wants six numbers X,Y,Z,ROLL,PITCH,YAW, got '%s'\n", arg);
        return -1;
    }
    o->have_init_pose = true;
    return 0;
}

static int set_paper(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)num, (void)err;
    o->solver = MFNS_POSE_MODE_PAPER;
    return 0;
}

static int set_verbose(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)num, (void)err;
    o->verbose = true;
    return 0;
}

static int set_quiet(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)num, (void)err;
    o->quiet = true;
    return 0;
}

static int set_mlock(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)arg, (void)num, (void)err;
    o->mlock = true;
    return 0;
}

static int set_last_exit(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)num, (void)err;
    o->last_exit = arg;
    return 0;
}

static int set_fixlog(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)num, (void)err;
    o->fixlog_dir = arg;
    return 0;
}

static int set_fixlog_rotate(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)st, (void)num;
    char kb[16] = {0};
    const char *comma = strchr(arg, ',');
    const size_t n = comma != NULL ? (size_t)(comma - arg) : 0u;
    if (comma == NULL || n == 0u || n >= sizeof kb) {
        fprintf(err, "mfns-nav: --fixlog-rotate wants KB,FILES, got '%s'\n", arg);
        return -1;
    }
    memcpy(kb, arg, n);
    if (!parse_u32(kb, 1, 1024u * 1024u, &o->fixlog_file_kb) || !parse_u32(comma + 1, 1, 1000000, &o->fixlog_files)) {
        fprintf(err, "mfns-nav: --fixlog-rotate wants KB,FILES (1..1048576, 1..1000000), got '%s'\n", arg);
        return -1;
    }
    return 0;
}

static int set_help(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err);

#define NAV_OPT_ROW(ID, name, sc, kind, meta, lo, hi, wants, set, help) {name, sc, kind, meta, lo, hi, wants, set, help},
static const nav_opt_row_t k_opts[NAV_OPT_COUNT] = {NAV_OPTS(NAV_OPT_ROW, NAV_OPTS_SKIP)};
#undef NAV_OPT_ROW

#define NAV_OPT_GETOPT(ID, name, sc, kind, meta, lo, hi, wants, set, help)                                            \
    {name, (kind) == NAV_OPT_FLAG ? no_argument : required_argument, NULL, NAV_OPT_VAL0 + NAV_OPT_##ID},
enum { NAV_OPT_VAL0 = 256 }; /* getopt_long's value of row i: NAV_OPT_VAL0 + i, above every short option */
static const struct option k_getopt[NAV_OPT_COUNT + 1] = {NAV_OPTS(NAV_OPT_GETOPT, NAV_OPTS_SKIP){NULL, 0, NULL, 0}};
#undef NAV_OPT_GETOPT

_Static_assert(MFNS_CAM_MAX_TIMEOUT_MS >= 5000, "the configuration's timeout_ms (1..5000) is within --timeout-ms");

/* ---- --help and --help-man, from the table ---- */

#define HELP_COL 22 /* where the help text begins: "  --name META" and its padding */

static void usage(FILE *f)
{
    fprintf(f, "usage: mfns-nav --table FILE (--replay DIR | --v4l2 | --libcamera) [options]\n"
               "       mfns-nav --config FILE [options]\n\n"
               "The MFNS flight program: camera frames -> beacon centroids -> pose -> telemetry.\n\n");
    for (int i = 0; i < (int)NAV_OPT_COUNT; i++) {
        const nav_opt_row_t *r = &k_opts[i];
        char spec[64];
        const char *meta_sep = r->meta != NULL ? " " : "", *meta = r->meta != NULL ? r->meta : "";
        if (r->short_name != 0) {
            (void)snprintf(spec, sizeof spec, "-%c, --%s%s%s", r->short_name, r->name, meta_sep, meta);
        } else {
            (void)snprintf(spec, sizeof spec, "--%s%s%s", r->name, meta_sep, meta);
        }
        const char *s = spec;
        const int w = (int)strlen(s);
        fprintf(f, "  %s%*s", s, w < HELP_COL - 3 ? HELP_COL - 2 - w : 2, "");
        for (const char *h = r->help; *h != '\0'; h++) { /* a '\n' in the help continues in the column */
            fputc(*h, f);
            if (*h == '\n') {
                fprintf(f, "%*s", HELP_COL, "");
            }
        }
        fputc('\n', f);
    }
    fprintf(f,
            "Board %s: --v4l2 cameras %s %s %s, --baud %d, --sync-window-ms %u.\n"
            "Configuration keys (--config; docs/operations.md):",
            MFNS_BOARD_NAME, MFNS_BOARD_CAM_X, MFNS_BOARD_CAM_Y, MFNS_BOARD_CAM_Z, MFNS_BOARD_BAUD,
            MFNS_SYNC_WINDOW_US_DEFAULT / 1000u);
    for (int k = 0; k < (int)NAV_CFG_KEY_COUNT; k++) {
        fprintf(f, " %s", nav_config_key_name((nav_config_key_t)k));
    }
    fprintf(f, ".\nExit status: 0 ok, 2 bad usage or input (table, cameras, telemetry target),\n"
               "3 telemetry incomplete (write errors, or a link that never opened: nothing sent).\n");
}

/* Text for roff: a leading '.' or '\'' escaped, '\\' doubled, '-' as "\-". */
static void roff_text(FILE *f, const char *s)
{
    for (bool bol = true; *s != '\0'; s++) {
        if (bol && (*s == '.' || *s == '\'')) {
            fputs("\\&", f);
        }
        if (*s == '\\') {
            fputs("\\\\", f);
        } else if (*s == '-') {
            fputs("\\-", f);
        } else {
            fputc(*s, f);
        }
        bol = *s == '\n';
    }
}

static void man_page(FILE *f)
{
    static const char *const k_type[] = {[NAV_CFG_T_TEXT] = "text", [NAV_CFG_T_PATH] = "an absolute path",
                                         [NAV_CFG_T_BOOL] = "yes or no", [NAV_CFG_T_U32] = "a number",
                                         [NAV_CFG_T_WORD] = "v4l2 or libcamera"};
    fprintf(f, ".TH MFNS-NAV 1 \"\" \"%s\" \"MFNS\"\n.SH NAME\nmfns-nav \\- the MFNS navigation computer's flight "
               "program\n.SH SYNOPSIS\n.B mfns-nav\n\\-\\-table FILE (\\-\\-replay DIR | \\-\\-v4l2 | "
               "\\-\\-libcamera) [options]\n.br\n.B mfns-nav\n\\-\\-config FILE [options]\n.SH OPTIONS\n",
            MFNS_VERSION_STR);
    for (int i = 0; i < (int)NAV_OPT_COUNT; i++) {
        const nav_opt_row_t *r = &k_opts[i];
        /* the tag on one line (.TP's): .B \-\-name, .BI "\-\-name " META, .BR \-v ", " \-\-name */
        if (r->short_name != 0) {
            fprintf(f, ".TP\n.BR \\-%c \", \" \\-\\-", r->short_name);
        } else {
            fprintf(f, ".TP\n.B%s\\-\\-", r->meta != NULL ? "I \"" : " ");
        }
        roff_text(f, r->name);
        if (r->meta != NULL) {
            fprintf(f, " \" ");
            roff_text(f, r->meta);
        }
        fputc('\n', f);
        roff_text(f, r->help);
        if (r->kind == NAV_OPT_U32) {
            fprintf(f, "\n(%u..%u)", r->lo, r->hi);
        }
        fputc('\n', f);
    }
    fprintf(f, ".SH CONFIGURATION\n\\-\\-config FILE (the board's %s) reads `key = value' lines; an option on "
               "the command line overrides its key (docs/operations.md).\n", NAV_CONFIG_DEFAULT_PATH);
    for (int k = 0; k < (int)NAV_CFG_KEY_COUNT; k++) {
        const nav_config_key_t key = (nav_config_key_t)k;
        fprintf(f, ".TP\n.B %s\n", nav_config_key_name(key));
        fprintf(f, "%s", k_type[nav_config_key_type(key)]);
        if (nav_config_key_type(key) == NAV_CFG_T_U32) {
            fprintf(f, " %u..%u", nav_config_key_lo(key), nav_config_key_hi(key));
        }
        fprintf(f, "; the option \\-\\-");
        roff_text(f, nav_config_key_option(key));
        fputc('\n', f);
    }
    fprintf(f, ".SH BOARD\n%s: \\-\\-v4l2 cameras %s %s %s, \\-\\-baud %d, \\-\\-sync\\-window\\-ms %u.\n"
               ".SH EXIT STATUS\n0 ok, 2 bad usage or input (table, cameras, telemetry target), 3 telemetry "
               "incomplete (write errors, or a link that never opened: nothing sent).\n"
               ".SH SEE ALSO\n/usr/share/doc/mfns-nav/\n",
            MFNS_BOARD_NAME, MFNS_BOARD_CAM_X, MFNS_BOARD_CAM_Y, MFNS_BOARD_CAM_Z, MFNS_BOARD_BAUD,
            MFNS_SYNC_WINDOW_US_DEFAULT / 1000u);
}

static int set_help(nav_opts_t *o, parse_state_t *st, const char *arg, uint32_t num, FILE *err)
{
    (void)o, (void)arg, (void)num, (void)err;
    if (st->id == NAV_OPT_HELP) {
        usage(st->out);
    } else if (st->id == NAV_OPT_HELP_MAN) {
        man_page(st->out);
    } else {
        fprintf(st->out, "mfns-nav %s (board %s)\n", MFNS_VERSION_STR, MFNS_BOARD_NAME);
    }
    return 1;
}

/* ---- the parser ---- */

/* The table's row of getopt_long's answer c (a long option's value or a short letter), or -1. */
static int row_of(int c)
{
    for (int i = 0; i < (int)NAV_OPT_COUNT; i++) {
        if (c == NAV_OPT_VAL0 + i || (k_opts[i].short_name != 0 && c == k_opts[i].short_name)) {
            return i;
        }
    }
    return -1;
}

/* One option: its number checked against the table's range, then its setter. */
static int apply_option(nav_opts_t *o, parse_state_t *st, int row, const char *arg, FILE *err)
{
    const nav_opt_row_t *r = &k_opts[row];
    uint32_t num = 0;
    if (r->kind == NAV_OPT_U32 && !parse_u32(arg, r->lo, r->hi, &num)) {
        if (r->wants != NULL) {
            fprintf(err, "mfns-nav: --%s wants %s, got '%s'\n", r->name, r->wants, arg);
        } else {
            fprintf(err, "mfns-nav: --%s wants %u..%u, got '%s'\n", r->name, r->lo, r->hi, arg);
        }
        return -1;
    }
    st->id = (nav_opt_id_t)row;
    return r->set(o, st, arg, num, err);
}

/* After the line: the file's cameras, then what the program cannot run. */
static int finish(nav_opts_t *o, parse_state_t *st, FILE *err)
{
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        if (st->cam_override[k] == NULL && st->ff.cam[k] != NULL && o->backend != MFNS_CAM_BACKEND_REPLAY) {
            st->cam_override[k] = st->ff.cam[k]; /* the file's camera, unless the line names one */
        }
    }
    const char *why = NULL;
    if (o->table_path == NULL) {
        why = "--table FILE (or the configuration's 'table') is required (see --help)";
    } else if (o->backend == MFNS_CAM_BACKEND_COUNT_) {
        why = "choose the cameras: --replay DIR, --v4l2 or --libcamera (see --help)";
    } else if (o->tc_kind == NAV_TC_LINK && o->tlm_kind != NAV_TLM_SERIAL && o->tlm_kind != NAV_TLM_PATH) {
        why = "--uplink reads commands from the telemetry link: give --serial or --tty";
    } else if (o->tc_insecure && o->tc_key_path != NULL) {
        why = "--tc-key and --tc-insecure exclude each other";
    } else if (o->tc_key_path != NULL && o->state_dir == NULL) {
        why = "--tc-key needs --state-dir DIR (the anti-replay boot epoch is kept there)";
    } else if (o->tc_kind != NAV_TC_NONE && o->tc_key_path == NULL && !o->tc_insecure) {
        why = "a command input needs --tc-key FILE --state-dir DIR (signed commands), or "
              "--tc-insecure to accept them without authentication (docs/uplink.md)";
    }
    for (int k = 0; k < MFNS_NUM_CAMERAS && why == NULL; k++) {
        if (st->cam_override[k] != NULL) {
            if (o->backend == MFNS_CAM_BACKEND_REPLAY) {
                why = "--cam-x/y/z do not apply to --replay";
            } else {
                o->cam_path[k] = st->cam_override[k];
            }
        }
    }
    if (why != NULL) {
        fprintf(err, "mfns-nav: %s\n", why);
        return -1;
    }
    return 0;
}

/* The defaults, and the configuration file's keys when --config names one. */
static int start(int argc, char **argv, nav_opts_t *o, parse_state_t *st, FILE *err)
{
    memset(o, 0, sizeof *o);
    o->backend = MFNS_CAM_BACKEND_COUNT_;
    o->frame_timeout_ms = NAV_OPT_TIMEOUT_MS_DEFAULT;
    o->sync_window_us = MFNS_SYNC_WINDOW_US_DEFAULT;
    o->baud = MFNS_BOARD_BAUD;
    o->solver = MFNS_POSE_MODE_ML;
    o->config_path = find_config(argc, argv);
    if (o->config_path == NULL) {
        return 0;
    }
    char msg[NAV_CONFIG_ERR_LEN + 64];
    if (nav_config_load(o->config_path, &o->cfg, msg, sizeof msg) != 0) {
        fprintf(err, "mfns-nav: configuration %s\n", msg);
        return -1;
    }
    if (nav_config_check_trust(&o->cfg, (uint32_t)geteuid(), msg, sizeof msg) != 0) {
        fprintf(err, "mfns-nav: configuration %s:%s\n", o->config_path, msg + 4); /* "line N: ..." -> ":N: ..." */
        return -1;
    }
    return apply_config(o, &st->ff, err);
}

int nav_opts_parse(int argc, char **argv, nav_opts_t *o, FILE *out, FILE *err)
{
    parse_state_t st;
    memset(&st, 0, sizeof st);
    st.out = out;
    if (start(argc, argv, o, &st, err) != 0) {
        return -1;
    }
    char shorts[NAV_OPT_COUNT + 1] = {0};
    for (size_t i = 0, n = 0; i < (size_t)NAV_OPT_COUNT; i++) {
        if (k_opts[i].short_name != 0) {
            shorts[n++] = k_opts[i].short_name; /* only flags have a short name (no ':') */
        }
    }
    optind = 1;
    opterr = 0;
    for (int guard = 0; guard < argc + 1; guard++) {
        const int c = getopt_long(argc, argv, shorts, k_getopt, NULL);
        if (c == -1) {
            break;
        }
        const int row = row_of(c);
        if (row < 0) {
            fprintf(err, "mfns-nav: unknown or incomplete option '%s' (see --help)\n", argv[optind - 1]);
            return -1;
        }
        const int rc = apply_option(o, &st, row, optarg, err);
        if (rc != 0) {
            return rc;
        }
    }
    if (optind < argc) {
        fprintf(err, "mfns-nav: unexpected argument '%s' (see --help)\n", argv[optind]);
        return -1;
    }
    return finish(o, &st, err);
}
