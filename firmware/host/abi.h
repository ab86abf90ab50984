/* abi.h -- sizeof of the C core's API structs, so that the foreign-function
 * mirrors of the host tools (Python ctypes, host_tools/mfns/core/flight.py) can
 * check their layout against the library they load. Host-only (firmware/host:
 * linked into libmfns_core.so and the unit tests, never into the flight
 * image). The enumerators are positions the Python side passes as integers:
 * append, never reorder.
 */
#ifndef MFNS_ABI_H
#define MFNS_ABI_H

#include <stdint.h>

typedef enum {
    MFNS_POSE_ABI_RIG = 0,
    MFNS_POSE_ABI_MAP,
    MFNS_POSE_ABI_FRAME,
    MFNS_POSE_ABI_ASSOC,
    MFNS_POSE_ABI_POSE,
    MFNS_POSE_ABI_CONFIG,
    MFNS_POSE_ABI_SOLUTION,
} mfns_pose_abi_t;

/* sizeof the pose solver's struct what (pose.h); 0 for an unknown one. */
uint32_t mfns_pose_abi_size(mfns_pose_abi_t what);

typedef enum {
    MFNS_ACQ_ABI_STATE = 0,  /* mfns_acq_t */
    MFNS_ACQ_ABI_PROGRESS,   /* mfns_acq_progress_t */
    MFNS_ACQ_ABI_INDEX,      /* mfns_beacon_index_t */
    MFNS_ACQ_ABI_EMIT,       /* mfns_beacon_emit_t */
    MFNS_ACQ_ABI_PARAMS,     /* mfns_bidx_params_t */
    MFNS_ACQ_ABI_CERTIFY,    /* mfns_certify_result_t (acquire_certify.h) */
    MFNS_ACQ_ABI_CYCLE,      /* mfns_acq_cycle_t (acquire_cycle.h) */
} mfns_acq_abi_t;

/* sizeof the acquisition's struct what (acquire.h and its callers' headers);
 * 0 for an unknown one. */
uint32_t mfns_acq_abi_size(mfns_acq_abi_t what);

#endif /* MFNS_ABI_H */
