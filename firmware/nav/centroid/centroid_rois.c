/* centroid_rois.c -- tracking windows around predicted positions
 * (mfns_centroid_make_rois, centroid.h). */
#include <math.h>
#include <stddef.h>

#include "firmware/nav/centroid/centroid.h"

static bool rois_touch(const mfns_roi_t *a, const mfns_roi_t *b)
{
    return a->x0 <= b->x1 && b->x0 <= a->x1 && a->y0 <= b->y1 && b->y0 <= a->y1;
}

mfns_centroid_status_t mfns_centroid_make_rois(const float (*uv)[2], uint16_t n_pred, uint16_t half_size_px,
                                               uint16_t width, uint16_t height, mfns_roi_t *rois, uint16_t max_rois,
                                               uint16_t *n_rois)
{
    if (n_rois != NULL) {
        *n_rois = 0u;
    }
    if ((uv == NULL && n_pred > 0u) || rois == NULL || n_rois == NULL) {
        return MFNS_CENTROID_ERR_NULL;
    }
    if (width == 0u || height == 0u || width > MFNS_CENTROID_MAX_DIM || height > MFNS_CENTROID_MAX_DIM) {
        return MFNS_CENTROID_ERR_SIZE;
    }
    if (max_rois > MFNS_CENTROID_MAX_ROIS) {
        max_rois = MFNS_CENTROID_MAX_ROIS;
    }
    uint16_t n = 0;
    for (uint16_t i = 0; i < n_pred; i++) {
        const float u = uv[i][0], v = uv[i][1];
        if (!(u >= -0.5f && v >= -0.5f && u < (float)width - 0.5f && v < (float)height - 0.5f)) {
            continue;
        }
        const int32_t cu = (int32_t)lroundf(u), cv = (int32_t)lroundf(v), h = half_size_px;
        mfns_roi_t r;
        r.x0 = (uint16_t)(cu - h > 0 ? cu - h : 0);
        r.y0 = (uint16_t)(cv - h > 0 ? cv - h : 0);
        r.x1 = (uint16_t)(cu + h + 1 < (int32_t)width ? cu + h + 1 : (int32_t)width);
        r.y1 = (uint16_t)(cv + h + 1 < (int32_t)height ? cv + h + 1 : (int32_t)height);
        /* absorb every window the new one touches; growth may reach more, so
         * repeat until none is left (each round removes one of <= MFNS_CENTROID_MAX_ROIS) */
        bool merged = true;
        for (uint16_t round = 0; merged && round <= MFNS_CENTROID_MAX_ROIS; round++) {
            merged = false;
            for (uint16_t k = 0; k < n; k++) {
                if (rois_touch(&r, &rois[k])) {
                    r.x0 = r.x0 < rois[k].x0 ? r.x0 : rois[k].x0;
                    r.y0 = r.y0 < rois[k].y0 ? r.y0 : rois[k].y0;
                    r.x1 = r.x1 > rois[k].x1 ? r.x1 : rois[k].x1;
                    r.y1 = r.y1 > rois[k].y1 ? r.y1 : rois[k].y1;
                    rois[k] = rois[n - 1u];
                    n--;
                    merged = true;
                    break;
                }
            }
        }
        if (n >= max_rois) {
            *n_rois = n;
            return MFNS_CENTROID_ERR_ROI;
        }
        rois[n++] = r;
    }
    *n_rois = n;
    return MFNS_CENTROID_OK;
}
