/* ground_out.c -- CSV and JSON Lines writers of the ground station. */
#define _DEFAULT_SOURCE /* gmtime_r under -std=c11 */

#include "ground/ground_out.h"
#include "ground/ground_row.h"

#include <errno.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>

static const char *const k_file_stem[TLM_NUM_TYPES] = {"nav", "camera", "housekeeping", "events", "fixobs"};

#define VAL_LEN GROUND_ROW_VAL_LEN
typedef ground_row_t row_t;

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

void ground_row_num(row_t *r, const char *name, long long v, int decimals)
{
    r->name[r->n] = name;
    ground_fmt_fixed(r->val[r->n], VAL_LEN, v, decimals);
    r->quoted[r->n] = 0;
    r->n++;
}

/* A binary32 printed with 9 significant digits: parsing the text gives back
 * the same float (the shortest count that round-trips every binary32). */
void ground_row_f32(row_t *r, const char *name, float v)
{
    r->name[r->n] = name;
    snprintf(r->val[r->n], VAL_LEN, "%.9g", (double)v);
    r->quoted[r->n] = 0;
    r->n++;
}

void ground_row_str(row_t *r, const char *name, const char *s)
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

void ground_row_hex32(row_t *r, const char *name, uint32_t v)
{
    char hex[VAL_LEN];
    snprintf(hex, sizeof hex, "0x%08lx", (unsigned long)v);
    ground_row_str(r, name, hex);
}

void ground_row_q30(row_t *r, const char *name, int32_t v)
{
    /* v / 2^30 is exact in a double; 10 decimals are below half the wire step
     * (4.7e-10), so the text gives back the integer */
    r->name[r->n] = name;
    snprintf(r->val[r->n], VAL_LEN, "%.10f", (double)v / (double)TLM_Q30_SCALE);
    r->quoted[r->n] = 0;
    r->n++;
}

/* t_s, seq, the packet's columns (ground_cols_gen.c), utc and time_source
 * (its UTC: time_corr.h), ground_utc (when it was received). */
static void build_row(const tlm_packet_t *p, int64_t pkt_utc_us, time_src_t src, int64_t utc_us, row_t *r)
{
    r->n = 0;
    r->name[0] = "t_s";
    ground_fmt_time(r->val[0], VAL_LEN, &p->time);
    r->quoted[0] = 0;
    r->n = 1;
    ground_row_num(r, "seq", p->seq, 0);
    ground_row_fields(p, r);
    r->name[r->n] = "utc";
    ground_fmt_utc(r->val[r->n], VAL_LEN, pkt_utc_us);
    r->quoted[r->n] = 1;
    r->n++;
    ground_row_str(r, "time_source", time_corr_src_name(src));
    r->name[r->n] = "ground_utc";
    ground_fmt_utc(r->val[r->n], VAL_LEN, utc_us);
    r->quoted[r->n] = 1;
    r->n++;
}

int ground_out_open(ground_out_t *o, const char *dir, char *err, size_t errlen)
{
    memset(o, 0, sizeof *o);
    time_corr_init(&o->corr);
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
        build_row(&p, 0, TIME_SRC_GROUND_RECEIPT, 0, &r);
        for (int c = 0; c < r.n; c++) {
            fprintf(o->csv[t], "%s%s", c ? "," : "", r.name[c]);
        }
        fputc('\n', o->csv[t]);
    }
    return 0;
}

int ground_out_packet(ground_out_t *o, const tlm_packet_t *p, int64_t rx_utc_us, int64_t *pkt_utc_us)
{
    if ((unsigned)p->type >= TLM_NUM_TYPES) {
        return -1;
    }
    time_src_t src = TIME_SRC_GROUND_RECEIPT;
    const int64_t utc = time_corr_packet(&o->corr, p, rx_utc_us, &src);
    if (pkt_utc_us != NULL) {
        *pkt_utc_us = utc;
    }
    row_t r;
    build_row(p, utc, src, rx_utc_us, &r);
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
    /* each CSV row whole on disk as it is decoded: a reader following the folder live
     * (`mfns live --follow`, docs/robotics.md) sees it at once, not a stdio buffer later */
    const int flushed = fflush(c);
    return (flushed != 0 || ferror(c) || ferror(j)) ? -1 : 0;
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
            "\"seq_gaps\": %lu, \"seq_lost\": %lu, \"seq_back\": %lu, \"seq_late\": %lu, \"packets\": {",
            seconds, (unsigned long)s->bytes, (unsigned long)s->frames_ok, (unsigned long)s->crc_errors,
            (unsigned long)s->truncated, (unsigned long)s->oversize, (unsigned long)s->bad_packets,
            (unsigned long)s->resyncs, (unsigned long)s->bytes_discarded, (unsigned long)s->seq_gaps,
            (unsigned long)s->seq_lost, (unsigned long)s->seq_back, (unsigned long)s->seq_late);
    for (int t = 0; t < (int)TLM_NUM_TYPES; t++) {
        fprintf(f, "%s\"%s\": {\"packets\": %lu, \"gaps\": %lu, \"lost\": %lu, \"back\": %lu, \"late\": %lu}",
                t ? ", " : "", tlm_type_name((tlm_type_t)t), (unsigned long)s->type[t].packets,
                (unsigned long)s->type[t].gaps, (unsigned long)s->type[t].lost, (unsigned long)s->type[t].back,
                (unsigned long)s->type[t].late);
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
