/* ground_out.c -- CSV and JSON Lines writers of the ground station. */
#define _DEFAULT_SOURCE /* gmtime_r under -std=c11 */

#include "ground_out.h"

#include <errno.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

static const char *const k_file_stem[TLM_NUM_TYPES] = {"nav", "camera", "housekeeping", "events"};

#define MAX_COLS 56
#define VAL_LEN 32

typedef struct {
    const char *name[MAX_COLS];
    char val[MAX_COLS][VAL_LEN];
    int quoted[MAX_COLS]; /* JSON string (names, hex) rather than number */
    int n;
} row_t;

void ground_fmt_fixed(char *buf, size_t len, long long v, int decimals)
{
    if (decimals <= 0) {
        snprintf(buf, len, "%lld", v);
        return;
    }
    if (decimals > 9) {
        decimals = 9; /* the widest wire unit is 1e-6 */
    }
    long long p = 1;
    for (int i = 0; i < decimals; i++) {
        p *= 10;
    }
    /* magnitude in unsigned so LLONG_MIN cannot overflow */
    const unsigned long long mag = v < 0 ? 0ull - (unsigned long long)v : (unsigned long long)v;
    snprintf(buf, len, "%s%llu.%0*llu", v < 0 ? "-" : "", mag / (unsigned long long)p, decimals,
             mag % (unsigned long long)p);
}

void ground_fmt_time(char *buf, size_t len, const tlm_time_t *t)
{
    const unsigned long long us =
        (unsigned long long)t->coarse_s * 1000000ull + (((unsigned long long)t->fine * 1000000ull + 32768ull) >> 16);
    snprintf(buf, len, "%llu.%06llu", us / 1000000ull, us % 1000000ull);
}

static void col_num(row_t *r, const char *name, long long v, int decimals)
{
    r->name[r->n] = name;
    ground_fmt_fixed(r->val[r->n], VAL_LEN, v, decimals);
    r->quoted[r->n] = 0;
    r->n++;
}

/* A binary32 printed with 9 significant digits: parsing the text gives back
 * the same float (the shortest count that round-trips every binary32). */
static void col_f32(row_t *r, const char *name, float v)
{
    r->name[r->n] = name;
    snprintf(r->val[r->n], VAL_LEN, "%.9g", (double)v);
    r->quoted[r->n] = 0;
    r->n++;
}

static void col_str(row_t *r, const char *name, const char *s)
{
    r->name[r->n] = name;
    snprintf(r->val[r->n], VAL_LEN, "%s", s);
    r->quoted[r->n] = 1;
    r->n++;
}

void ground_fmt_utc(char *buf, size_t len, int64_t utc_us)
{
    const int64_t sec = utc_us >= 0 ? utc_us / 1000000 : -((-utc_us + 999999) / 1000000);
    const long usec = (long)(utc_us - sec * 1000000);
    const time_t t = (time_t)sec;
    struct tm tm;
    if (gmtime_r(&t, &tm) == NULL) {
        snprintf(buf, len, "?");
        return;
    }
    snprintf(buf, len, "%04d-%02d-%02dT%02d:%02d:%02d.%06ldZ", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday,
             tm.tm_hour, tm.tm_min, tm.tm_sec, usec);
}

/* Column names of the covariance's upper triangle, row-major over the ROS
 * order (x, y, z, rx, ry, rz): cov_x_x, cov_x_y, .. cov_rz_rz. */
static const char *const k_cov_col[TLM_NAV_COV_N] = {
    "cov_x_x",   "cov_x_y",   "cov_x_z",   "cov_x_rx",  "cov_x_ry",  "cov_x_rz",  "cov_y_y",
    "cov_y_z",   "cov_y_rx",  "cov_y_ry",  "cov_y_rz",  "cov_z_z",   "cov_z_rx",  "cov_z_ry",
    "cov_z_rz",  "cov_rx_rx", "cov_rx_ry", "cov_rx_rz", "cov_ry_ry", "cov_ry_rz", "cov_rz_rz"};

/* Events whose arg1 is a CRC-32: printed in hex as in housekeeping.csv. */
static int event_arg1_is_crc(uint16_t code)
{
    return code == TLM_EVT_TABLE_LOADED || code == TLM_EVT_TABLE_REFUSED;
}

static void col_hex32(row_t *r, const char *name, uint32_t v)
{
    char hex[VAL_LEN];
    snprintf(hex, sizeof hex, "0x%08lx", (unsigned long)v);
    col_str(r, name, hex);
}

static void build_row(const tlm_packet_t *p, int64_t utc_us, row_t *r)
{
    r->n = 0;
    r->name[0] = "t_s";
    ground_fmt_time(r->val[0], VAL_LEN, &p->time);
    r->quoted[0] = 0;
    r->n = 1;
    col_num(r, "seq", p->seq, 0);
    static const char *const axis[3] = {"x", "y", "z"};
    switch (p->type) {
    case TLM_TYPE_NAV: {
        static const char *const pos[3] = {"x_mm", "y_mm", "z_mm"};
        static const char *const att[3] = {"roll_deg", "pitch_deg", "yaw_deg"};
        static const char *const spos[3] = {"sigma_x_mm", "sigma_y_mm", "sigma_z_mm"};
        static const char *const satt[3] = {"sigma_roll_deg", "sigma_pitch_deg", "sigma_yaw_deg"};
        const tlm_nav_t *n = &p->u.nav;
        col_num(r, "cycle", n->cycle, 0);
        col_str(r, "status", tlm_nav_status_name(n->status));
        col_num(r, "reason", n->reason, 0);
        col_str(r, "mode", tlm_mode_name(n->mode));
        col_num(r, "beacons_used", n->beacons_used, 0);
        col_num(r, "cams_used", n->cams_used, 0);
        col_num(r, "iterations", n->iterations, 0);
        for (int k = 0; k < 3; k++) {
            col_num(r, pos[k], n->pos_um[k], 3);
        }
        for (int k = 0; k < 3; k++) {
            col_num(r, att[k], n->att_udeg[k], 6);
        }
        for (int k = 0; k < 3; k++) {
            col_num(r, spos[k], n->sigma_pos_um[k], 3);
        }
        for (int k = 0; k < 3; k++) {
            col_num(r, satt[k], n->sigma_att_udeg[k], 6);
        }
        col_num(r, "residual_rms_px", n->residual_rms_mpx, 3);
        static const char *const q[4] = {"q_w", "q_x", "q_y", "q_z"};
        for (int k = 0; k < 4; k++) {
            /* v / 2^30 is exact in a double; 10 decimals are below half the
             * wire step (4.7e-10), so the text gives back the integer */
            r->name[r->n] = q[k];
            snprintf(r->val[r->n], VAL_LEN, "%.10f", (double)n->q_q30[k] / (double)TLM_Q30_SCALE);
            r->quoted[r->n] = 0;
            r->n++;
        }
        for (unsigned k = 0; k < TLM_NAV_COV_N; k++) {
            col_f32(r, k_cov_col[k], n->cov[k]);
        }
        break;
    }
    case TLM_TYPE_CAMERA: {
        const tlm_camera_t *c = &p->u.camera;
        col_num(r, "cycle", c->cycle, 0);
        col_str(r, "camera", c->camera < 3u ? axis[c->camera] : "?");
        col_str(r, "state", tlm_cam_state_name(c->state));
        col_num(r, "blobs", c->blobs, 0);
        col_num(r, "beacons_identified", c->beacons_identified, 0);
        col_num(r, "exposure_us", c->exposure_us, 0);
        col_num(r, "gain_db", c->gain_cdb, 2);
        col_num(r, "frame_seq", c->frame_seq, 0);
        col_num(r, "frames_dropped", c->frames_dropped, 0);
        break;
    }
    case TLM_TYPE_HK: {
        const tlm_hk_t *h = &p->u.hk;
        col_num(r, "cycle", h->cycle, 0);
        col_str(r, "mode", tlm_mode_name(h->mode));
        col_num(r, "cpu_load_pct", h->cpu_load_permille, 1);
        col_num(r, "cycle_p50_us", h->cycle_p50_us, 0);
        col_num(r, "cycle_p95_us", h->cycle_p95_us, 0);
        col_num(r, "cycle_p99_us", h->cycle_p99_us, 0);
        col_num(r, "cycle_max_us", h->cycle_max_us, 0);
        col_num(r, "n_cycles", h->n_cycles, 0);
        col_num(r, "n_fix", h->n_fix, 0);
        col_num(r, "n_no_fix", h->n_no_fix, 0);
        col_num(r, "n_tlm_dropped", h->n_tlm_dropped, 0);
        col_num(r, "n_cam_errors", h->n_cam_errors, 0);
        col_hex32(r, "table_crc32", h->table_crc32);
        col_num(r, "n_acquire", h->n_acquire, 0);
        col_num(r, "acq_units_max", h->acq_units_max, 0);
        col_num(r, "acq_units_last", h->acq_units_last, 0);
        col_num(r, "acq_band_last", h->acq_band_last, 0);
        col_num(r, "acq_best_last", h->acq_best_last, 0);
        col_num(r, "n_degraded", h->n_degraded, 0);
        col_num(r, "n_cmd_accepted", h->n_cmd_accepted, 0);
        col_num(r, "n_cmd_rejected", h->n_cmd_rejected, 0);
        col_num(r, "cmd_seq_last", h->cmd_seq_last, 0);
        col_num(r, "cams_enabled", h->cams_enabled, 0);
        break;
    }
    case TLM_TYPE_EVENT:
    default: {
        const tlm_event_t *e = &p->u.event;
        col_num(r, "cycle", e->cycle, 0);
        col_str(r, "event", tlm_event_name(e->code));
        col_num(r, "code", e->code, 0);
        col_str(r, "severity", tlm_severity_name(e->severity));
        col_num(r, "subject", e->subject, 0);
        col_num(r, "arg0", e->arg0, 0);
        if (event_arg1_is_crc(e->code)) {
            col_hex32(r, "arg1", (uint32_t)e->arg1);
        } else {
            col_num(r, "arg1", e->arg1, 0);
        }
        break;
    }
    }
    r->name[r->n] = "ground_utc";
    ground_fmt_utc(r->val[r->n], VAL_LEN, utc_us);
    r->quoted[r->n] = 1;
    r->n++;
}

int ground_out_open(ground_out_t *o, const char *dir, char *err, size_t errlen)
{
    memset(o, 0, sizeof *o);
    if (strlen(dir) >= sizeof o->dir - 32u) {
        snprintf(err, errlen, "output folder name too long");
        return -1;
    }
    snprintf(o->dir, sizeof o->dir, "%s", dir);
    if (mkdir(dir, 0777) != 0 && errno != EEXIST) {
        snprintf(err, errlen, "cannot create output folder %s: %s", dir, strerror(errno));
        return -1;
    }
    for (int t = 0; t < (int)TLM_NUM_TYPES; t++) {
        char path[512];
        snprintf(path, sizeof path, "%s/%s.csv", dir, k_file_stem[t]);
        o->csv[t] = fopen(path, "w");
        snprintf(path, sizeof path, "%s/%s.jsonl", dir, k_file_stem[t]);
        o->jsonl[t] = fopen(path, "w");
        if (o->csv[t] == NULL || o->jsonl[t] == NULL) {
            snprintf(err, errlen, "cannot write %s: %s", path, strerror(errno));
            (void)ground_out_close(o);
            return -1;
        }
        /* The header comes from the same column list as the rows. */
        tlm_packet_t p;
        memset(&p, 0, sizeof p);
        p.type = (tlm_type_t)t;
        row_t r;
        build_row(&p, 0, &r);
        for (int c = 0; c < r.n; c++) {
            fprintf(o->csv[t], "%s%s", c ? "," : "", r.name[c]);
        }
        fputc('\n', o->csv[t]);
    }
    return 0;
}

int ground_out_packet(ground_out_t *o, const tlm_packet_t *p, int64_t utc_us)
{
    if ((unsigned)p->type >= TLM_NUM_TYPES) {
        return -1;
    }
    row_t r;
    build_row(p, utc_us, &r);
    FILE *c = o->csv[p->type];
    FILE *j = o->jsonl[p->type];
    fputc('{', j);
    for (int k = 0; k < r.n; k++) {
        fprintf(c, "%s%s", k ? "," : "", r.val[k]);
        fprintf(j, "%s\"%s\": %s%s%s", k ? ", " : "", r.name[k], r.quoted[k] ? "\"" : "", r.val[k],
                r.quoted[k] ? "\"" : "");
    }
    fputc('\n', c);
    fputs("}\n", j);
    o->rows[p->type]++;
    return (ferror(c) || ferror(j)) ? -1 : 0;
}

int ground_out_stats(const ground_out_t *o, const tlm_decoder_stats_t *s, double seconds)
{
    char path[512];
    snprintf(path, sizeof path, "%s/stats.json", o->dir);
    FILE *f = fopen(path, "w");
    if (f == NULL) {
        return -1;
    }
    fprintf(f,
            "{\"seconds\": %.3f, \"bytes\": %lu, \"frames_ok\": %lu, \"crc_errors\": %lu, \"truncated\": %lu, "
            "\"oversize\": %lu, \"bad_packets\": %lu, \"resyncs\": %lu, \"bytes_discarded\": %lu, "
            "\"seq_gaps\": %lu, \"seq_lost\": %lu, \"packets\": {",
            seconds, (unsigned long)s->bytes, (unsigned long)s->frames_ok, (unsigned long)s->crc_errors,
            (unsigned long)s->truncated, (unsigned long)s->oversize, (unsigned long)s->bad_packets,
            (unsigned long)s->resyncs, (unsigned long)s->bytes_discarded, (unsigned long)s->seq_gaps,
            (unsigned long)s->seq_lost);
    for (int t = 0; t < (int)TLM_NUM_TYPES; t++) {
        fprintf(f, "%s\"%s\": {\"packets\": %lu, \"gaps\": %lu, \"lost\": %lu}", t ? ", " : "",
                tlm_type_name((tlm_type_t)t), (unsigned long)s->type[t].packets, (unsigned long)s->type[t].gaps,
                (unsigned long)s->type[t].lost);
    }
    fputs("}}\n", f);
    return fclose(f) == 0 ? 0 : -1;
}

int ground_out_close(ground_out_t *o)
{
    int rc = 0;
    for (int t = 0; t < (int)TLM_NUM_TYPES; t++) {
        if (o->csv[t] != NULL && fclose(o->csv[t]) != 0) {
            rc = -1;
        }
        if (o->jsonl[t] != NULL && fclose(o->jsonl[t]) != 0) {
            rc = -1;
        }
        o->csv[t] = NULL;
        o->jsonl[t] = NULL;
    }
    return rc;
}
