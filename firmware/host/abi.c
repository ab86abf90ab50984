/* abi.c -- see abi.h. */
#include "firmware/host/abi.h"

#include "firmware/nav/acquire/acquire.h"
#include "firmware/host/acquire_certify.h"
#include "firmware/nav/acquire/acquire_cycle.h"
#include "firmware/nav/map/beacon_index.h"
#include "firmware/nav/pose/pose.h"

uint32_t mfns_pose_abi_size(mfns_pose_abi_t what)
{
    switch (what) {
    case MFNS_POSE_ABI_RIG:
        return (uint32_t)sizeof(mfns_rig_t);
    case MFNS_POSE_ABI_MAP:
        return (uint32_t)sizeof(mfns_beacon_map_t);
    case MFNS_POSE_ABI_FRAME:
        return (uint32_t)sizeof(mfns_obs_frame_t);
    case MFNS_POSE_ABI_ASSOC:
        return (uint32_t)sizeof(mfns_pose_assoc_t);
    case MFNS_POSE_ABI_POSE:
        return (uint32_t)sizeof(mfns_pose_t);
    case MFNS_POSE_ABI_CONFIG:
        return (uint32_t)sizeof(mfns_pose_config_t);
    case MFNS_POSE_ABI_SOLUTION:
        return (uint32_t)sizeof(mfns_pose_solution_t);
    }
    return 0;
}

uint32_t mfns_acq_abi_size(mfns_acq_abi_t what)
{
    switch (what) {
    case MFNS_ACQ_ABI_STATE:
        return (uint32_t)sizeof(mfns_acq_t);
    case MFNS_ACQ_ABI_PROGRESS:
        return (uint32_t)sizeof(mfns_acq_progress_t);
    case MFNS_ACQ_ABI_INDEX:
        return (uint32_t)sizeof(mfns_beacon_index_t);
    case MFNS_ACQ_ABI_EMIT:
        return (uint32_t)sizeof(mfns_beacon_emit_t);
    case MFNS_ACQ_ABI_PARAMS:
        return (uint32_t)sizeof(mfns_bidx_params_t);
    case MFNS_ACQ_ABI_CERTIFY:
        return (uint32_t)sizeof(mfns_certify_result_t);
    case MFNS_ACQ_ABI_CYCLE:
        return (uint32_t)sizeof(mfns_acq_cycle_t);
    }
    return 0;
}
