/* acquire_anchor.c -- the acquisition's frame set-up (acquire_internal.h):
 * the blobs as body-frame rays, and the anchors (acquire.h, step 1). */
#include <math.h>
#include <stddef.h>

#include "firmware/nav/acquire/acquire_internal.h"
#include "firmware/nav/pose/pose_init.h"
#include "math/units.h"

/* Cross-camera angles: the two rays start at different camera centres, so
 * their angle differs from the angle the pair subtends at one point by up to
 * the parallax of the baseline at the nearest range. */
#define MIN_PARALLAX_RANGE_MM 200.0f

/* Anchors of a pair alone in its image (a blob of another camera each). */
#define MAX_CROSS_PER_PAIR 2

/* A third blob in the pair's image whose triangle with it is this flat
 * (height over the longest side, in the image) is not taken as the anchor's
 * third: the images of three beacons on one line (a planned layout on a grid
 * has many: issue 27, three beacons at x = 2000, z = 300 mm) give a gP3P whose
 * rotation about that line is unobservable, so no hypothesis of that anchor
 * verifies the truth. Measured on the planned module layout: views of 7 blobs
 * whose every anchor was such a triple (three blobs per camera, so no
 * cross-camera third) were never identified, at any budget. The next nearest
 * blob of the image that is not on the line is taken, else the pair gets
 * thirds from the other cameras. An order: a flat triangle of two cameras'
 * blobs is still reached by the cross thirds. */
#define FLAT_TRIANGLE_RATIO 0.05f

float mfns_acq_ray_angle(const mfns_acq_blob_t *a, const mfns_acq_blob_t *b)
{
    const float cs = mfns_v3_dot(a->d, b->d);
    return acosf(cs > 1.0f ? 1.0f : (cs < -1.0f ? -1.0f : cs));
}

float mfns_acq_parallax_pad(const mfns_acq_blob_t *a, const mfns_acq_blob_t *b)
{
    if (a->cam == b->cam) {
        return 0.0f;
    }
    const float base = mfns_v3_norm(mfns_v3_sub(a->c, b->c));
    const float s = base / MIN_PARALLAX_RANGE_MM;
    return s >= 1.0f ? MFNS_PI_F : asinf(s);
}

bool mfns_acq_setup(mfns_acq_t *q)
{
    q->nb = 0;
    for (int c = 0; c < MFNS_NUM_CAMERAS; c++) {
        for (int i = 0; i < MFNS_MAX_OBS_PER_CAMERA; i++) {
            q->cam_blob[c][i] = -1;
        }
        for (int i = 0; i < q->frame->count[c]; i++) {
            const mfns_obs_t *o = &q->frame->obs[c][i];
            if (!isfinite(o->u) || !isfinite(o->v) || !isfinite(o->x) || !isfinite(o->y)) {
                return false;
            }
            mfns_acq_blob_t *b = &q->blobs[q->nb];
            b->cam = (uint8_t)c;
            b->idx = (uint8_t)i;
            mfns_pose_ray(&q->rig->cam[c], o->x, o->y, &b->c, &b->d);
            q->cam_blob[c][i] = (int16_t)q->nb;
            q->nb++;
        }
        q->gate_n[c] = MFNS_ACQ_MINIMAL_GATE_FACTOR * q->cfg->s.track_gate_px / q->rig->cam[c].k.fx;
    }
    return true;
}

/* The blob of camera cam nearest (in angle) to blob i, other than those in
 * excl[0..ne), or -1. */
static int nearest_in_cam(const mfns_acq_t *q, int cam, int i, const int *excl, int ne)
{
    int best = -1;
    float bc = -2.0f;
    for (int m = 0; m < q->frame->count[cam]; m++) {
        const int b = q->cam_blob[cam][m];
        bool skip = b == i;
        for (int e = 0; e < ne; e++) {
            skip = skip || b == excl[e];
        }
        if (skip) {
            continue;
        }
        const float cs = mfns_v3_dot(q->blobs[i].d, q->blobs[b].d);
        if (cs > bc) {
            bc = cs;
            best = b;
        }
    }
    return best;
}

/* Are the three blobs (rays from one camera centre) nearly on one line in
 * the image? |d_i . (d_j x d_k)| is twice the triangle's area on the unit
 * sphere (to first order), the largest pair angle its longest side. */
bool mfns_acq_flat_triangle(const mfns_acq_t *q, int i, int j, int k)
{
    const mfns_acq_blob_t *bi = &q->blobs[i], *bj = &q->blobs[j], *bk = &q->blobs[k];
    const float area2 = fabsf(mfns_v3_dot(bi->d, mfns_v3_cross(bj->d, bk->d)));
    float l = mfns_acq_ray_angle(bi, bj);
    const float l2 = mfns_acq_ray_angle(bi, bk);
    const float l3 = mfns_acq_ray_angle(bj, bk);
    l = l2 > l ? l2 : l;
    l = l3 > l ? l3 : l;
    return !(area2 > FLAT_TRIANGLE_RATIO * l * l);
}

/* The pair's third in its own image: the nearest blob to i (but j) whose
 * triangle with the pair is not flat; -1 none. */
static int third_in_cam(const mfns_acq_t *q, int cam, int i, int j)
{
    int ex[MFNS_MAX_OBS_PER_CAMERA];
    int ne = 0;
    ex[ne++] = j;
    for (int m = 0; m < q->frame->count[cam] && ne < MFNS_MAX_OBS_PER_CAMERA; m++) {
        const int k = nearest_in_cam(q, cam, i, ex, ne);
        if (k < 0) {
            return -1;
        }
        if (!mfns_acq_flat_triangle(q, i, j, k)) {
            return k;
        }
        ex[ne++] = k;
    }
    return -1;
}

/* Anchors: each blob with its nearest neighbour in the same image, nearest
 * pairs first (insertion into a short sorted list). */
void mfns_acq_make_anchors(mfns_acq_t *q)
{
    /* the pairs: each blob with its nearest in the same image, nearest first */
    struct {
        int16_t i, j; /* the blobs */
        float ang;    /* their angle (rad) */
    } pair[MFNS_ACQ_MAX_ANCHORS];
    int np = 0;
    for (int i = 0; i < q->nb; i++) {
        const int j = nearest_in_cam(q, q->blobs[i].cam, i, NULL, 0);
        bool dup = j < 0;
        for (int a = 0; a < np && !dup; a++) {
            dup = pair[a].i == j && pair[a].j == i;
        }
        if (dup) {
            continue;
        }
        const float t = mfns_acq_ray_angle(&q->blobs[i], &q->blobs[j]);
        int pos = np;
        while (pos > 0 && pair[pos - 1].ang > t) {
            pos--;
        }
        if (pos >= MFNS_ACQ_MAX_ANCHORS) {
            continue;
        }
        const int last = np < MFNS_ACQ_MAX_ANCHORS ? np : MFNS_ACQ_MAX_ANCHORS - 1;
        for (int m = last; m > pos; m--) {
            pair[m] = pair[m - 1];
        }
        pair[pos].i = (int16_t)i;
        pair[pos].j = (int16_t)j;
        pair[pos].ang = t;
        np = np < MFNS_ACQ_MAX_ANCHORS ? np + 1 : np;
    }
    /* each pair with its third blob: the next nearest in its image (first,
     * for every pair), else (its image holds only the pair) up to
     * MAX_CROSS_PER_PAIR anchors with a blob of another camera each, one per
     * camera first, since one such triple may be ill-conditioned where another
     * is not. Capped per pair so that a pair of one real blob and a
     * reflection cannot take every anchor slot (measured: a view of 14 + 1 + 1
     * blobs with a reflection beside the lone blob of the third camera was
     * never identified, its six anchors all holding the reflection). */
    q->na = 0;
    for (int pass = 0; pass < 2; pass++) {
        for (int a = 0; a < np && q->na < MFNS_ACQ_MAX_ANCHORS; a++) {
            const int cam = q->blobs[pair[a].i].cam;
            const int k = third_in_cam(q, cam, pair[a].i, pair[a].j);
            if ((pass == 0) != (k >= 0)) {
                continue;
            }
            int third[MAX_CROSS_PER_PAIR];
            int nt = 0;
            if (k >= 0) {
                third[nt++] = k;
            } else {
                /* the nearest blob of each other camera, then the next ones */
                for (int round = 0; round < MFNS_MAX_OBS_PER_CAMERA && nt < MAX_CROSS_PER_PAIR; round++) {
                    bool any = false;
                    for (int c = 0; c < MFNS_NUM_CAMERAS && nt < MAX_CROSS_PER_PAIR; c++) {
                        if (c == cam || round >= q->frame->count[c]) {
                            continue;
                        }
                        any = true;
                        third[nt++] = q->cam_blob[c][round];
                    }
                    if (!any) {
                        break;
                    }
                }
            }
            for (int t = 0; t < nt && q->na < MFNS_ACQ_MAX_ANCHORS; t++) {
                const int kk = third[t];
                mfns_acq_anchor_t *an = &q->anchor[q->na++];
                an->i = pair[a].i;
                an->j = pair[a].j;
                an->k = (int16_t)kk;
                an->cross = k < 0;
                int ex2[3] = {an->j, kk, -1};
                an->v[0] = (int16_t)(an->cross ? -1 : nearest_in_cam(q, cam, an->i, ex2, 2));
                ex2[2] = an->v[0];
                an->v[1] = (int16_t)(an->v[0] < 0 ? -1 : nearest_in_cam(q, cam, an->i, ex2, 3));
                /* too few in the anchor's image: blobs of the other cameras */
                for (int o = 0; o < q->nb && an->v[1] < 0; o++) {
                    if (o == an->i || o == an->j || o == an->k || o == an->v[0] || q->blobs[o].cam == cam) {
                        continue;
                    }
                    an->v[an->v[0] < 0 ? 0 : 1] = (int16_t)o;
                }
            }
        }
    }
    q->progress.anchors = (uint8_t)q->na;
}
