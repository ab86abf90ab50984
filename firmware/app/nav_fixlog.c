/* nav_fixlog.c -- see nav_fixlog.h. */
#define _POSIX_C_SOURCE 200809L
#include "firmware/app/nav_fixlog.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#define FIXLOG_IDLE_NS 10000000L /* the writer looks at the ring every 10 ms */
#define FIXLOG_NAME_FMT "%s/fixlog_%06u.tlm"
#define FIXLOG_MAX_WRITE_TRIES 1000u /* bounded write loop: partial writes of one chunk */

static bool usable(const mfns_pose_solution_t *s)
{
    return s->status == MFNS_POSE_OK || s->status == MFNS_POSE_DEGRADED;
}

static void put(tlm_packet_t *p, uint32_t cycle, uint64_t t_us, int k, uint16_t id, const mfns_obs_t *o, bool used)
{
    memset(p, 0, sizeof *p);
    p->type = TLM_TYPE_FIXOBS;
    p->time = tlm_time_from_us(t_us);
    tlm_fixobs_t *f = &p->u.fixobs;
    f->cycle = cycle;
    f->camera = (uint8_t)k;
    f->beacon_id = id;
    f->used = used ? 1U : 0U;
    f->uv_px[0] = o->u;
    f->uv_px[1] = o->v;
    f->cov_px2[0] = o->cov_px2[0];
    f->cov_px2[1] = o->cov_px2[1];
    f->cov_px2[2] = o->cov_px2[2];
}

/* The beacon predicted nearest to o at the fix's pose, within gate_px, that
 * no observation of camera k is associated with; -1 none. */
static int nearest_free(const mfns_camera_t *cam, const mfns_pose_t *pose, const mfns_beacon_map_t *map,
                        const mfns_pose_solution_t *s, const mfns_obs_frame_t *obs, int k, const mfns_obs_t *o,
                        float gate_px)
{
    int best = -1;
    float best_d2 = gate_px * gate_px;
    for (uint16_t b = 0; b < map->count && b < MFNS_MAX_BEACONS; b++) {
        float uv[2];
        if (mfns_cam_project(cam, pose, map->beacon[b].p_w, uv, NULL) != MFNS_PROJ_OK) {
            continue;
        }
        const float du = uv[0] - o->u, dv = uv[1] - o->v, d2 = du * du + dv * dv;
        if (d2 >= best_d2) {
            continue;
        }
        bool taken = false;
        for (uint16_t j = 0; j < obs->count[k] && j < MFNS_MAX_OBS_PER_CAMERA && !taken; j++) {
            taken = s->assoc.beacon[k][j] == (int16_t)b;
        }
        if (!taken) {
            best = (int)b;
            best_d2 = d2;
        }
    }
    return best;
}

unsigned nav_fixlog_packets(const mfns_nav_output_t *out, const mfns_obs_frame_t *obs, const mfns_rig_t *rig,
                            const mfns_beacon_map_t *map, float gate_px, uint32_t cycle, uint64_t t_us,
                            tlm_packet_t *pkts, unsigned max)
{
    if (out == NULL || obs == NULL || rig == NULL || map == NULL || pkts == NULL || !usable(&out->sol)) {
        return 0;
    }
    const mfns_pose_solution_t *s = &out->sol;
    unsigned n = 0;
    for (int k = 0; k < MFNS_NUM_CAMERAS; k++) {
        for (uint16_t i = 0; i < obs->count[k] && i < MFNS_MAX_OBS_PER_CAMERA && n < max; i++) {
            const int16_t b = s->assoc.beacon[k][i];
            const mfns_obs_t *o = &obs->obs[k][i];
            if (b >= 0 && (uint16_t)b < map->count && s->inlier[k][i] != 0U) {
                put(&pkts[n++], cycle, t_us, k, map->beacon[b].id, o, true);
            } else if (gate_px > 0.0f) {
                const int nb = b >= 0 && (uint16_t)b < map->count
                                   ? (int)b
                                   : nearest_free(&rig->cam[k], &s->pose, map, s, obs, k, o, gate_px);
                if (nb >= 0) {
                    put(&pkts[n++], cycle, t_us, k, map->beacon[nb].id, o, false);
                }
            }
        }
    }
    for (unsigned i = 0; i < n; i++) {
        pkts[i].u.fixobs.index = (uint8_t)i;
        pkts[i].u.fixobs.count = (uint8_t)n;
    }
    return n;
}

/* ---------------------------------------------------------------- writer */
static int open_next(nav_fixlog_t *l)
{
    char path[NAV_FIXLOG_PATH_MAX + 32u];
    if (l->fd >= 0) {
        (void)close(l->fd);
        l->fd = -1;
    }
    l->file_no++;
    if (l->file_no > l->files_max) {
        (void)snprintf(path, sizeof path, FIXLOG_NAME_FMT, l->dir, l->file_no - l->files_max);
        (void)unlink(path); /* absent: nothing to rotate out */
    }
    (void)snprintf(path, sizeof path, FIXLOG_NAME_FMT, l->dir, l->file_no);
    l->fd = open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    l->in_file = 0;
    return l->fd >= 0 ? 0 : -1;
}

static bool write_all(int fd, const uint8_t *b, size_t n)
{
    for (unsigned t = 0; t < FIXLOG_MAX_WRITE_TRIES && n > 0; t++) {
        const ssize_t w = write(fd, b, n);
        if (w < 0 && errno == EINTR) {
            continue;
        }
        if (w <= 0) {
            return false;
        }
        b += (size_t)w;
        n -= (size_t)w;
    }
    return n == 0;
}

/* The records whose bytes the writer just took (n bytes, whole records: head
 * moves per record), counted written or lost. */
static void account(nav_fixlog_t *l, size_t n, bool ok)
{
    const size_t rh = atomic_load_explicit(&l->rec_head, memory_order_acquire);
    unsigned k = 0;
    for (size_t guard = 0; guard < NAV_FIXLOG_REC_SLOTS && n > 0u && l->rec_tail < rh; guard++) {
        const size_t len = l->rec_len[l->rec_tail % NAV_FIXLOG_REC_SLOTS];
        n = n >= len ? n - len : 0u;
        l->rec_tail++;
        k++;
    }
    atomic_fetch_add(ok ? &l->written_records : &l->lost_records, k);
}

/* Everything the loop has published: whole records (head moves per record). */
static void write_pending(nav_fixlog_t *l)
{
    const size_t head = atomic_load_explicit(&l->head, memory_order_acquire);
    const size_t tail = atomic_load_explicit(&l->tail, memory_order_relaxed);
    if (head == tail) {
        return;
    }
    if (l->fd < 0 || l->in_file >= l->file_bytes_max) {
        if (open_next(l) != 0) {
            atomic_fetch_add(&l->write_errors, 1u);
            account(l, head - tail, false);
            atomic_store_explicit(&l->tail, head, memory_order_release); /* given up, never waited for */
            return;
        }
    }
    const size_t n = head - tail, at = tail % NAV_FIXLOG_RING_BYTES;
    const size_t first = n < NAV_FIXLOG_RING_BYTES - at ? n : NAV_FIXLOG_RING_BYTES - at;
    bool ok = write_all(l->fd, l->ring + at, first);
    if (ok && n > first) {
        ok = write_all(l->fd, l->ring, n - first);
    }
    if (!ok) {
        atomic_fetch_add(&l->write_errors, 1u);
    }
    account(l, n, ok);
    l->in_file += n;
    atomic_store_explicit(&l->tail, head, memory_order_release);
}

static void *writer(void *arg)
{
    nav_fixlog_t *l = arg;
    const struct timespec idle = {0, FIXLOG_IDLE_NS};
    for (;;) { /* ends when told to stop and the ring is empty */
        const bool stopping = atomic_load_explicit(&l->stop, memory_order_acquire);
        write_pending(l);
        if (stopping) {
            write_pending(l); /* what the loop published before it asked */
            break;
        }
        (void)nanosleep(&idle, NULL);
    }
    if (l->fd >= 0) {
        (void)close(l->fd);
        l->fd = -1;
    }
    return NULL;
}

/* The highest fixlog number already in dir: a restart continues after it. */
static uint32_t last_file_no(const char *dir)
{
    uint32_t best = 0;
    DIR *d = opendir(dir);
    if (d == NULL) {
        return 0;
    }
    for (struct dirent *e = readdir(d); e != NULL; e = readdir(d)) { /* bounded by the directory */
        /* fixlog_NNNNNN.tlm exactly */
        const char *name = e->d_name;
        if (strlen(name) != 17u || strncmp(name, "fixlog_", 7u) != 0 || strcmp(name + 13, ".tlm") != 0) {
            continue;
        }
        char *end = NULL;
        const unsigned long no = strtoul(name + 7, &end, 10);
        if (end == name + 13 && no > best && no <= UINT32_MAX) {
            best = (uint32_t)no;
        }
    }
    (void)closedir(d);
    return best;
}

int nav_fixlog_open(nav_fixlog_t *l, const char *dir, uint32_t file_bytes, uint32_t files)
{
    memset(l, 0, sizeof *l);
    l->fd = -1;
    if (dir == NULL || strlen(dir) >= NAV_FIXLOG_PATH_MAX) {
        fprintf(stderr, "mfns-nav: --fixlog: directory name missing or too long\n");
        return -1;
    }
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        fprintf(stderr, "mfns-nav: --fixlog %s: %s\n", dir, strerror(errno));
        return -1;
    }
    struct stat st;
    if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) {
        fprintf(stderr, "mfns-nav: --fixlog %s: not a directory\n", dir);
        return -1;
    }
    (void)snprintf(l->dir, sizeof l->dir, "%s", dir);
    l->file_bytes_max = file_bytes > 0u ? file_bytes : NAV_FIXLOG_FILE_BYTES;
    l->files_max = files > 0u ? files : NAV_FIXLOG_FILES;
    l->file_no = last_file_no(dir);
    tlm_encoder_init(&l->enc);
    atomic_init(&l->head, 0);
    atomic_init(&l->tail, 0);
    atomic_init(&l->records, 0u);
    atomic_init(&l->dropped_records, 0u);
    atomic_init(&l->write_errors, 0u);
    atomic_init(&l->written_records, 0u);
    atomic_init(&l->lost_records, 0u);
    atomic_init(&l->rec_head, 0u);
    atomic_init(&l->stop, false);
    if (pthread_create(&l->thread, NULL, writer, l) != 0) {
        fprintf(stderr, "mfns-nav: --fixlog: cannot start the writer thread\n");
        return -1;
    }
    l->open = true;
    return 0;
}

bool nav_fixlog_record(nav_fixlog_t *l, const tlm_packet_t *nav_pkt, const tlm_packet_t *fix, unsigned n_fix)
{
    if (l == NULL || !l->open || nav_pkt == NULL || nav_pkt->type != TLM_TYPE_NAV || n_fix == 0u ||
        n_fix > NAV_FIXLOG_MAX_ASSOC || fix == NULL) {
        return false;
    }
    /* encode the whole record first: only whole records enter the ring */
    size_t len = 0;
    tlm_encoder_t enc = l->enc; /* committed only when the record is kept */
    for (unsigned i = 0; i <= n_fix; i++) {
        tlm_packet_t p = i == 0u ? *nav_pkt : fix[i - 1u];
        size_t n = 0;
        if (tlm_frame_encode(&enc, &p, l->scratch + len, sizeof l->scratch - len, &n) != TLM_OK) {
            atomic_fetch_add(&l->dropped_records, 1u);
            return false;
        }
        len += n;
    }
    const size_t head = atomic_load_explicit(&l->head, memory_order_relaxed);
    const size_t tail = atomic_load_explicit(&l->tail, memory_order_acquire);
    if (NAV_FIXLOG_RING_BYTES - (head - tail) < len) {
        atomic_fetch_add(&l->dropped_records, 1u); /* the writer is behind: drop, never wait */
        return false;
    }
    const size_t at = head % NAV_FIXLOG_RING_BYTES;
    const size_t first = len < NAV_FIXLOG_RING_BYTES - at ? len : NAV_FIXLOG_RING_BYTES - at;
    memcpy(l->ring + at, l->scratch, first);
    memcpy(l->ring, l->scratch + first, len - first);
    /* its length for the writer's count; the length ring cannot overrun: a
     * record is more than RING_BYTES / REC_SLOTS bytes, so the byte ring is
     * full first */
    const size_t rh = atomic_load_explicit(&l->rec_head, memory_order_relaxed);
    l->rec_len[rh % NAV_FIXLOG_REC_SLOTS] = (uint32_t)len;
    atomic_store_explicit(&l->rec_head, rh + 1u, memory_order_release);
    atomic_store_explicit(&l->head, head + len, memory_order_release);
    l->enc = enc;
    atomic_fetch_add(&l->records, 1u);
    return true;
}

void nav_fixlog_close(nav_fixlog_t *l)
{
    if (l == NULL || !l->open) {
        return;
    }
    atomic_store_explicit(&l->stop, true, memory_order_release);
    (void)pthread_join(l->thread, NULL);
    l->open = false;
}
