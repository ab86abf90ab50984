/* cam_sync.h -- moved to firmware/frames/cam_sync.h (issue 41: the frame
 * policies in one folder). This forward stays only while nav_opts.c (another
 * branch's work on the options table) still includes the old path; include
 * "firmware/frames/cam_sync.h" in new code, and delete this file once
 * nav_opts.c does. */
#ifndef MFNS_APP_CAM_SYNC_FORWARD_H
#define MFNS_APP_CAM_SYNC_FORWARD_H

#include "firmware/frames/cam_sync.h"

#endif
