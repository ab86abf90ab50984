"""The one Python binding of the C core (build/host-sim/lib/libmfns_core.so, `make lib`).

Every host tool and test that calls C code imports this module: it declares each C struct
the host passes (ctypes, field by field), each constant the host sizes arrays with, and the
prototype of each function it calls, and it loads the library in one place (`load`, in
the order of `lib_path`; a clear error when it is missing).

How the declarations are held to the headers: they are the input of a generator,
`binding_check.py` (standard library only), which writes `binding_check_gen.c`: for every
struct a `_Static_assert` on its size, on each field's offset and on each field's type
(`_Generic` on the field; arrays by element type and by the count of every dimension;
nested structs by their C type name; enums and pointers by the C type the declaration
names in `_c_types_`), and one on each constant. `make lib` (mk/binding.mk) checks the
generated file is current and compiles it with the core's headers and flags, so a binding
that disagrees with a header fails the build. tests/host/test_binding.py swaps two fields
of one size in a copy of these declarations and sees the compile fail.

Why this direction (declarations checked against the headers) rather than ctypes generated
from the headers: the headers stay the one contract and are not constrained by a parser;
parsing C needs clang's AST (pycparser is not available), and clang is not in the demo's
package set (mk/deps.sh), while the check needs only python3 and the gcc that builds the
library; and the Python side keeps its own names (V3.x, Pose.C_w_b) without a mapping
layer. The one thing a check cannot do that a generator would is add a field by itself:
a C field the binding does not declare moves the offsets after it or the size, and fails.

Each struct class carries `_c_ = (header, C type name)`; a nested struct or union without
a C name (an anonymous member) carries `_c_ = None` and is checked through its parent.
"""

from __future__ import annotations

import ctypes as ct
import os
from pathlib import Path

from .errors import MfnsError

REPO = Path(__file__).resolve().parents[3]
# the installed package's own library (the wheel's build step puts it there, host_tools/setup.py)
PACKAGE_LIB = Path(__file__).resolve().parents[1] / "libmfns_core.so"  # the package root (setup.py)
# the tree's build (`make lib`): what an editable install (make venv) loads
DEFAULT_LIB = REPO / "build" / "host-sim" / "lib" / "libmfns_core.so"

# --- constants (each checked against its C macro) ---------------------------------------
NUM_CAMERAS = 3
MAX_BEACONS = 256
MAX_NBR = 32
MAX_PAIRS = MAX_BEACONS * (MAX_BEACONS - 1) // 2
MAX_MEAS = 3 * 32
MAX_CERT = 16
MAX_MISSING = 3
MAX_OBS_PER_CAMERA = 32
NO_BEACON = -1
CALIB_PARAMS_PER_CAMERA = 15  # nav_settings.h mfns_calib_param_t (fx fy cx cy k1 k2 p1 p2 k3 theta r)
CALIB_PARAMS = NUM_CAMERAS * CALIB_PARAMS_PER_CAMERA
MAP_DATUM_PARAMS = 6  # nav_settings.h mfns_map_datum_t: shift x y z (mm), turn x y z (rad)
TC_PATH_MAX = 64
TC_SEC_MAC_LEN = 16
TC_UPLOAD_NAME_MAX = 32
TC_UPLOAD_SEG_LEN = 200
TC_MAX_AUTH = 8 + 205 + 10  # TC_MAX_PACKET (UPLOAD_DATA's 205 argument bytes) + security header
# pose.h mfns_pose_status_t: the solver's own status (the nav packet's nav_status_t differs)
POSE_OK, POSE_DEGRADED, POSE_NO_FIX = 0, 1, 2
PX_Q8_ONE = 256  # fixed.h: one pixel in px_q8 (1/256 px)
Q16_16_ONE = 65536  # fixed.h: one in Q16.16 (the grid's nodes)
UNDIST_GRID_ORIGIN_Q8 = -PX_Q8_ONE // 2  # undistort.h: a built grid's first node, pixel -0.5
UNDIST_BAD_INPUT = 1  # undistort.h mfns_undist_status_t
ACQ_SOURCES = ("NONE", "FRESH", "CARRIED")  # acquire_cycle.h mfns_acq_source_t, indexed by code

# (Python value, C expression): binding_check.py asserts each equal
CONSTANTS = {
    "NUM_CAMERAS": (NUM_CAMERAS, "MFNS_NUM_CAMERAS"),
    "MAX_BEACONS": (MAX_BEACONS, "MFNS_MAX_BEACONS"),
    "MAX_NBR": (MAX_NBR, "MFNS_BIDX_MAX_NBR"),
    "MAX_PAIRS": (MAX_PAIRS, "MFNS_BIDX_MAX_PAIRS"),
    "MAX_MEAS": (MAX_MEAS, "MFNS_ACQ_MAX_MEAS"),
    "MAX_CERT": (MAX_CERT, "MFNS_BIDX_MAX_CERT"),
    "MAX_MISSING": (MAX_MISSING, "MFNS_BIDX_MAX_MISSING"),
    "MAX_OBS_PER_CAMERA": (MAX_OBS_PER_CAMERA, "MFNS_MAX_OBS_PER_CAMERA"),
    "NO_BEACON": (NO_BEACON, "MFNS_POSE_NO_BEACON"),
    "CALIB_PARAMS": (CALIB_PARAMS, "MFNS_CALIB_PARAMS"),
    "MAP_DATUM_PARAMS": (MAP_DATUM_PARAMS, "MFNS_MAP_DATUM_PARAMS"),
    "TC_PATH_MAX": (TC_PATH_MAX, "TC_PATH_MAX"),
    "TC_SEC_MAC_LEN": (TC_SEC_MAC_LEN, "TC_SEC_MAC_LEN"),
    "TC_MAX_AUTH": (TC_MAX_AUTH, "TC_MAX_AUTH"),
    "TC_UPLOAD_NAME_MAX": (TC_UPLOAD_NAME_MAX, "TC_UPLOAD_NAME_MAX"),
    "TC_UPLOAD_SEG_LEN": (TC_UPLOAD_SEG_LEN, "TC_UPLOAD_SEG_LEN"),
    "POSE_OK": (POSE_OK, "MFNS_POSE_OK"),
    "POSE_DEGRADED": (POSE_DEGRADED, "MFNS_POSE_DEGRADED"),
    "POSE_NO_FIX": (POSE_NO_FIX, "MFNS_POSE_NO_FIX"),
    "PX_Q8_ONE": (PX_Q8_ONE, "MFNS_PX_Q8_ONE"),
    "Q16_16_ONE": (Q16_16_ONE, "MFNS_Q16_16_ONE"),
    # each name's position is its code: MFNS_ACQ_SRC_<name> == index, asserted at build
    **{f"ACQ_SRC_{n}": (i, f"MFNS_ACQ_SRC_{n}") for i, n in enumerate(ACQ_SOURCES)},
    "UNDIST_GRID_ORIGIN_Q8": (UNDIST_GRID_ORIGIN_Q8, "MFNS_UNDIST_GRID_ORIGIN_Q8"),
    "UNDIST_BAD_INPUT": (UNDIST_BAD_INPUT, "MFNS_UNDIST_BAD_INPUT"),
}


# --- math/ ---------------------------------------------------------------------------------
class V3(ct.Structure):
    _c_ = ("math/linalg.h", "mfns_v3_t")
    _fields_ = [("x", ct.c_float), ("y", ct.c_float), ("z", ct.c_float)]


class M3(ct.Structure):
    _c_ = ("math/linalg.h", "mfns_m3_t")
    _fields_ = [("m", (ct.c_float * 3) * 3)]


class Euler(ct.Structure):
    _c_ = ("math/rotation.h", "mfns_euler_t")
    _fields_ = [("roll", ct.c_float), ("pitch", ct.c_float), ("yaw", ct.c_float)]


class Intrinsics(ct.Structure):
    _c_ = ("math/lens.h", "mfns_intrinsics_t")
    _fields_ = [
        ("fx", ct.c_float),
        ("fy", ct.c_float),
        ("cx", ct.c_float),
        ("cy", ct.c_float),
        ("skew", ct.c_float),
        ("dist", ct.c_float * 5),
        ("width", ct.c_uint16),
        ("height", ct.c_uint16),
    ]


class CameraC(ct.Structure):
    _c_ = ("math/lens.h", "mfns_camera_t")
    _fields_ = [("k", Intrinsics), ("C_k_b", M3), ("r_bk_b", V3)]


class Rig(ct.Structure):
    _c_ = ("math/lens.h", "mfns_rig_t")
    _fields_ = [("cam", CameraC * NUM_CAMERAS)]


class Pose(ct.Structure):
    _c_ = ("math/lens.h", "mfns_pose_t")
    _fields_ = [("C_w_b", M3), ("r_bw_b", V3)]


class UndistGrid(ct.Structure):
    """mfns_undist_grid_t: the correction grid of one camera (nodes not owned)."""

    _c_ = ("math/undistort.h", "mfns_undist_grid_t")
    _c_types_ = {"node": "const q16_16_t (*)[2]"}
    _fields_ = [
        ("nx", ct.c_uint16),
        ("ny", ct.c_uint16),
        ("origin_u_q8", ct.c_int32),
        ("origin_v_q8", ct.c_int32),
        ("step_u_q8", ct.c_int32),
        ("step_v_q8", ct.c_int32),
        ("node", ct.POINTER(ct.c_int32 * 2)),
    ]


# --- firmware/nav/ -------------------------------------------------------------------------
class Beacon(ct.Structure):
    _c_ = ("firmware/nav/settings/nav_settings.h", "mfns_beacon_t")
    _fields_ = [("id", ct.c_uint16), ("p_w", V3), ("sigma_mm", ct.c_float)]


class BeaconMap(ct.Structure):
    _c_ = ("firmware/nav/settings/nav_settings.h", "mfns_beacon_map_t")
    _fields_ = [("count", ct.c_uint16), ("beacon", Beacon * MAX_BEACONS)]


class SolverSettings(ct.Structure):
    _c_ = ("firmware/nav/settings/nav_settings.h", "mfns_solver_settings_t")
    _fields_ = [
        ("max_iterations", ct.c_uint16),
        ("step_tol", ct.c_float),
        ("grad_tol", ct.c_float),
        ("huber_k", ct.c_float),
        ("outlier_gate_sigma", ct.c_float),
        ("max_residual_rms_sigma", ct.c_float),
        ("track_gate_px", ct.c_float),
        ("min_rcond", ct.c_float),
    ]


class CentroidSettings(ct.Structure):
    _c_ = ("firmware/nav/settings/nav_settings.h", "mfns_centroid_settings_t")
    _fields_ = [
        ("threshold_dn", ct.c_uint16),
        ("threshold_k_sigma", ct.c_float),
        ("min_area_px", ct.c_uint16),
        ("max_area_px", ct.c_uint16),
        ("max_elongation", ct.c_float),
        ("roi_half_size_px", ct.c_uint16),
        ("saturation_dn", ct.c_uint16),
        ("gain_dn_per_e_q12", ct.c_uint16),
    ]


class CalibCov(ct.Structure):
    """mfns_calib_cov_t (nav_settings.h): the calibration's covariance, 45 x 45."""

    _c_ = ("firmware/nav/settings/nav_settings.h", "mfns_calib_cov_t")
    _fields_ = [("present", ct.c_uint8), ("cov", (ct.c_float * CALIB_PARAMS) * CALIB_PARAMS)]


class MapDatum(ct.Structure):
    """mfns_map_datum_t (nav_settings.h): the map's shared rigid error, 6 x 6 over (shift mm,
    turn rad about c_w)."""

    _c_ = ("firmware/nav/settings/nav_settings.h", "mfns_map_datum_t")
    _fields_ = [
        ("present", ct.c_uint8),
        ("c_w", V3),
        ("cov", (ct.c_float * MAP_DATUM_PARAMS) * MAP_DATUM_PARAMS),
    ]


class PoseConfig(ct.Structure):
    _c_ = ("firmware/nav/pose/pose.h", "mfns_pose_config_t")
    _c_types_ = {
        "mode": "mfns_pose_mode_t",
        "calib_cov": "const mfns_calib_cov_t *",
        "datum": "const mfns_map_datum_t *",
    }
    _fields_ = [
        ("s", SolverSettings),
        ("sigma_px", ct.c_float),
        ("mode", ct.c_int),
        ("calib_cov", ct.POINTER(CalibCov)),
        ("datum", ct.POINTER(MapDatum)),
    ]


class Obs(ct.Structure):
    _c_ = ("firmware/nav/pose/pose.h", "mfns_obs_t")
    _fields_ = [
        ("u", ct.c_float),
        ("v", ct.c_float),
        ("x", ct.c_float),
        ("y", ct.c_float),
        ("cov_px2", ct.c_float * 3),
    ]


class ObsFrame(ct.Structure):
    _c_ = ("firmware/nav/pose/pose.h", "mfns_obs_frame_t")
    _fields_ = [
        ("count", ct.c_uint16 * NUM_CAMERAS),
        ("obs", (Obs * MAX_OBS_PER_CAMERA) * NUM_CAMERAS),
        ("dark", ct.c_uint8 * NUM_CAMERAS),
    ]


class Assoc(ct.Structure):
    _c_ = ("firmware/nav/pose/pose.h", "mfns_pose_assoc_t")
    _fields_ = [("beacon", (ct.c_int16 * MAX_OBS_PER_CAMERA) * NUM_CAMERAS)]


class PlanFix(ct.Structure):
    """mfns_plan_fix_t (firmware/host/plan_fix.h): the flight's verdict on one planned view."""

    _c_ = ("firmware/host/plan_fix.h", "mfns_plan_fix_t")
    _fields_ = [
        ("status", ct.c_int32),
        ("reason", ct.c_int32),
        ("pl_pos_mm", ct.c_float),
        ("pl_att_deg", ct.c_float),
        ("sigma_pos_mm", ct.c_float * 3),
        ("sigma_euler_deg", ct.c_float * 3),
        ("beacons_used", ct.c_uint16),
        ("cameras_used", ct.c_uint16),
        ("unmonitorable", ct.c_uint16),
        ("usable", ct.c_uint8),
        ("camera_unmonitored", ct.c_uint8),
    ]


class SolutionC(ct.Structure):
    _c_ = ("firmware/nav/pose/pose.h", "mfns_pose_solution_t")
    _c_types_ = {"status": "mfns_pose_status_t", "reason": "mfns_pose_reason_t"}
    _fields_ = [
        ("status", ct.c_int),
        ("reason", ct.c_int),
        ("pose", Pose),
        ("r_wb_w", V3),
        ("euler_deg", Euler),
        ("q_b_w", ct.c_float * 4),
        ("cov", (ct.c_float * 6) * 6),
        ("cov_ros", (ct.c_float * 6) * 6),
        ("sigma_pos_mm", ct.c_float * 3),
        ("sigma_euler_deg", ct.c_float * 3),
        ("beacons_used", ct.c_uint16),
        ("outliers", ct.c_uint16),
        ("cameras_used", ct.c_uint16),
        ("iterations", ct.c_uint16),
        ("hypotheses", ct.c_uint16),
        ("residual_rms_px", ct.c_float),
        ("residual_rms_sigma", ct.c_float),
        ("assoc", Assoc),
        ("inlier", (ct.c_uint8 * MAX_OBS_PER_CAMERA) * NUM_CAMERAS),
    ]


class BeaconEmit(ct.Structure):
    _c_ = ("firmware/nav/map/beacon_index.h", "mfns_beacon_emit_t")
    _fields_ = [("axis_w", V3), ("cos_half_angle", ct.c_float)]


class BeaconGeom(ct.Structure):
    _c_ = ("firmware/nav/map/beacon_index.h", "mfns_beacon_geom_t")
    _fields_ = [("emit", BeaconEmit), ("range_min_mm", ct.c_float), ("range_max_mm", ct.c_float)]


class BeaconIndex(ct.Structure):
    _c_ = ("firmware/nav/map/beacon_index.h", "mfns_beacon_index_t")
    _fields_ = [
        ("count", ct.c_uint16),
        ("k_nbr", ct.c_uint8),
        ("max_missing", ct.c_uint8),
        ("max_unexplained", ct.c_uint8),
        ("budget_units", ct.c_uint32),
        ("ws_min_w", V3),
        ("ws_max_w", V3),
        ("analysis_samples", ct.c_uint32),
        ("analysis_max_rival", ct.c_uint16),
        ("cert_inliers", ct.c_uint8 * (MAX_MISSING + 1)),
        ("geom", BeaconGeom * MAX_BEACONS),
        ("nbr_count", ct.c_uint8 * MAX_BEACONS),
        ("nbr", (ct.c_uint8 * MAX_NBR) * MAX_BEACONS),
        ("pair_lo", ct.c_uint8 * MAX_PAIRS),
        ("pair_hi", ct.c_uint8 * MAX_PAIRS),
    ]


class BidxParams(ct.Structure):
    _c_ = ("firmware/nav/map/beacon_index.h", "mfns_bidx_params_t")
    _fields_ = [
        ("k_nbr", ct.c_uint8),
        ("cert_inliers", ct.c_uint8),
        ("max_missing", ct.c_uint8),
        ("max_unexplained", ct.c_uint8),
        ("budget_units", ct.c_uint32),
    ]


class AcqProgress(ct.Structure):
    _c_ = ("firmware/nav/acquire/acquire.h", "mfns_acq_progress_t")
    _fields_ = [
        ("units", ct.c_uint32),
        ("units_total", ct.c_uint32),
        ("calls", ct.c_uint16),
        ("hypotheses", ct.c_uint32),
        ("verified", ct.c_uint16),
        ("anchors", ct.c_uint8),
        ("band", ct.c_uint8),
        ("best_inliers", ct.c_uint8),
        ("best_missing", ct.c_uint8),
        ("finished", ct.c_bool),
        ("budget_out", ct.c_bool),
        ("certified", ct.c_bool),
        ("completed", ct.c_bool),
        ("rivals", ct.c_uint8),
    ]


class AcqCycleReport(ct.Structure):
    _c_ = ("firmware/nav/acquire/acquire_cycle.h", "mfns_acq_cycle_report_t")
    _fields_ = [
        ("progress", AcqProgress),
        ("carried_units", ct.c_uint32),
        ("carry_age", ct.c_uint16),
        ("source", ct.c_uint8),
        ("carry_dropped", ct.c_bool),
        ("bridge_refused", ct.c_bool),
        ("catchup_steps", ct.c_uint16),
        ("catchup_pending", ct.c_bool),
    ]


class CertifyCase(ct.Structure):
    _c_ = ("firmware/host/acquire_certify.h", "mfns_certify_case_t")
    _fields_ = [
        ("sample", ct.c_uint32),
        ("n_blobs", ct.c_uint16),
        ("rival_inliers", ct.c_uint16),
        ("rival_missing", ct.c_uint16),
        ("truth_id", ct.c_uint16 * MAX_MEAS),
        ("rival_id", ct.c_int32 * MAX_MEAS),
    ]


class CertifyResult(ct.Structure):
    _c_ = ("firmware/host/acquire_certify.h", "mfns_certify_result_t")
    _fields_ = [
        ("samples", ct.c_uint32),
        ("usable", ct.c_uint32),
        ("truth_found", ct.c_uint32),
        ("ambiguous", ct.c_uint32),
        ("rival_hist", ct.c_uint32 * (MAX_CERT + 1)),
        ("max_rival", ct.c_uint16),
        ("rival_by_missing", ct.c_uint16 * (MAX_MISSING + 1)),
        ("cert_inliers", ct.c_uint8 * (MAX_MISSING + 1)),
        ("cert_capped", ct.c_uint8),
        ("worst", CertifyCase),
    ]


# --- firmware/tlm/ -------------------------------------------------------------------------
class TcPoseHint(ct.Structure):
    _c_ = ("firmware/tlm/tc_packets.h", "tc_pose_hint_t")
    _fields_ = [("pos_um", ct.c_int32 * 3), ("att_udeg", ct.c_int32 * 3)]


class TcUploadStart(ct.Structure):
    _c_ = ("firmware/tlm/tc_packets.h", "tc_upload_start_t")
    _fields_ = [("size", ct.c_uint32), ("crc32", ct.c_uint32), ("name", ct.c_char * TC_UPLOAD_NAME_MAX)]


class TcUploadData(ct.Structure):
    _c_ = ("firmware/tlm/tc_packets.h", "tc_upload_data_t")
    _fields_ = [("offset", ct.c_uint32), ("len", ct.c_uint8), ("bytes", ct.c_uint8 * TC_UPLOAD_SEG_LEN)]


class TcArgs(ct.Union):
    """The anonymous union `u` of tc_cmd_t (checked through TcCmd)."""

    _c_ = None
    _fields_ = [
        ("mode", ct.c_uint8),
        ("camera", ct.c_uint8),
        ("pose", TcPoseHint),
        ("path", ct.c_char * TC_PATH_MAX),
        ("upload_start", TcUploadStart),
        ("upload_data", TcUploadData),
    ]


class TcSec(ct.Structure):
    _c_ = ("firmware/tlm/tc_packets.h", "tc_sec_t")
    _fields_ = [
        ("present", ct.c_bool),
        ("spi", ct.c_uint16),
        ("arsn", ct.c_uint64),
        ("mac", ct.c_uint8 * TC_SEC_MAC_LEN),
        ("auth_len", ct.c_uint16),
        ("auth", ct.c_uint8 * TC_MAX_AUTH),
    ]


class TcCmd(ct.Structure):
    _c_ = ("firmware/tlm/tc_packets.h", "tc_cmd_t")
    _fields_ = [
        ("seq", ct.c_uint16),
        ("opcode", ct.c_uint8),
        ("have_seq", ct.c_bool),
        ("have_opcode", ct.c_bool),
        ("u", TcArgs),
        ("sec", TcSec),
    ]


# Every struct binding_check.py holds to the headers (nested anonymous ones through their parent).
STRUCTS = [
    V3,
    M3,
    Euler,
    Intrinsics,
    CameraC,
    Rig,
    Pose,
    UndistGrid,
    Beacon,
    BeaconMap,
    SolverSettings,
    CentroidSettings,
    CalibCov,
    PoseConfig,
    Obs,
    ObsFrame,
    Assoc,
    SolutionC,
    PlanFix,
    BeaconEmit,
    BeaconGeom,
    BeaconIndex,
    BidxParams,
    AcqProgress,
    AcqCycleReport,
    CertifyCase,
    CertifyResult,
    TcPoseHint,
    TcUploadStart,
    TcUploadData,
    TcSec,
    TcCmd,
]

# Runtime check of the loaded library (it may come from $MFNS_CORE_LIB, built elsewhere):
# mfns_pose_abi_size order (pose.h) and mfns_acq_abi_size order (acquire.h; None: opaque here).
POSE_ABI = [Rig, BeaconMap, ObsFrame, Assoc, Pose, PoseConfig, SolutionC]
ACQ_ABI = [None, AcqProgress, BeaconIndex, BeaconEmit, BidxParams, CertifyResult]
ACQ_ABI_STATE, ACQ_ABI_CYCLE = 0, len(ACQ_ABI)  # mfns_acq_t and mfns_acq_cycle_t: opaque buffers

# --- prototypes: name -> (restype, argtypes) ------------------------------------------------
_P = ct.POINTER
_F2 = ct.c_float * 2
_J26 = (ct.c_float * 6) * 2
_H66 = (ct.c_float * 6) * 6
_I32P = _P(ct.c_int32)
_U32 = ct.c_uint32
_VP = ct.c_void_p

PROTOTYPES: dict[str, tuple] = {
    # math/
    "mfns_cam_project": (ct.c_int, [_P(CameraC), _P(Pose), V3, _P(_F2), _P(_J26)]),
    "mfns_cam_project_c": (ct.c_int, [_P(Intrinsics), V3, _P(_F2), _VP]),
    "mfns_cam_distort": (None, [_P(Intrinsics), ct.c_float, ct.c_float, _P(ct.c_float), _P(ct.c_float), _VP]),
    "mfns_cam_in_image": (ct.c_bool, [_P(Intrinsics), ct.c_float, ct.c_float]),
    "mfns_m3_to_quat": (None, [M3, _P(ct.c_float)]),
    "mfns_undistort_iter": (
        ct.c_int,
        [_P(Intrinsics), ct.c_float, ct.c_float, ct.c_int, _P(ct.c_float), _P(ct.c_float), _P(ct.c_int)],
    ),
    "mfns_undistort_grid_px": (ct.c_int, [_P(UndistGrid), ct.c_int32, ct.c_int32, _I32P, _I32P]),
    "mfns_undist_grid_build": (
        ct.c_int,
        [_P(Intrinsics), ct.c_uint16, ct.c_uint16, _VP, ct.c_size_t, _P(UndistGrid)],
    ),
    "mfns_undist_grid_step": (ct.c_bool, [ct.c_uint16, ct.c_uint16, _I32P]),
    "mfns_undist_strerror": (ct.c_char_p, [ct.c_int]),
    # pose
    "mfns_pose_abi_size": (_U32, [ct.c_int]),
    "mfns_pose_config_default": (None, [_P(PoseConfig)]),
    "mfns_pose_refine": (
        ct.c_int,
        [_P(Rig), _P(BeaconMap), _P(ObsFrame), _P(Assoc), _P(Pose), _P(PoseConfig), _P(SolutionC)],
    ),
    "mfns_pose_track": (
        ct.c_int,
        [_P(Rig), _P(BeaconMap), _P(ObsFrame), _P(Pose), _P(PoseConfig), _P(SolutionC)],
    ),
    # (h = J^T R^-1 J, B = J^T R^-1 J_c or NULL, calibration covariance or NULL, map datum or
    # NULL, min_rcond, out)
    "mfns_pose_covariance": (ct.c_int, [_P(_H66), _VP, _VP, _VP, ct.c_float, _P(SolutionC)]),
    "mfns_pose_strerror": (ct.c_char_p, [ct.c_int]),
    # the planner's snapshot solve + integrity (plan_fix.h; settings NULL: the flight's defaults)
    "mfns_plan_fix": (
        ct.c_int,
        [_P(Rig), _P(BeaconMap), _P(ObsFrame), _P(Assoc), _P(Pose), _P(PoseConfig), _VP, _P(PlanFix)],
    ),
    "mfns_centroid_settings_default": (None, [_P(CentroidSettings)]),
    "mfns_solver_settings_default": (None, [_P(SolverSettings)]),
    # acquisition, map index, map analysis
    "mfns_acq_abi_size": (_U32, [ct.c_int]),
    "mfns_acquire": (
        ct.c_int,
        [_VP, _P(Rig), _P(BeaconMap), _P(BeaconIndex), _P(ObsFrame), _P(PoseConfig), _U32, _P(SolutionC)],
    ),
    "mfns_acq_resume": (ct.c_int, [_VP, _U32, _P(SolutionC)]),
    "mfns_acq_pending": (ct.c_bool, [_VP]),
    "mfns_acq_cycle_reset": (None, [_VP]),
    "mfns_acq_cycle_run": (
        ct.c_int,
        [
            _VP,
            _P(Rig),
            _P(BeaconMap),
            _P(BeaconIndex),
            _P(ObsFrame),
            _P(PoseConfig),
            _U32,
            _P(SolutionC),
            _P(AcqCycleReport),
        ],
    ),
    "mfns_bidx_params_default": (None, [_P(BidxParams)]),
    "mfns_bidx_build": (
        ct.c_int,
        [_P(Rig), _P(BeaconMap), _P(BeaconEmit), V3, V3, _P(BidxParams), _P(BeaconIndex)],
    ),
    "mfns_bidx_encode": (ct.c_int, [_P(BeaconIndex), _VP, _U32, _P(_U32)]),
    "mfns_bidx_section_size": (_U32, [_U32, _U32]),
    "mfns_bidx_strerror": (ct.c_char_p, [ct.c_int]),
    "mfns_certify": (
        ct.c_int,
        [
            _VP,
            _P(Rig),
            _P(BeaconMap),
            _P(BeaconIndex),
            _P(PoseConfig),
            _P(Pose),
            _U32,
            _U32,
            _P(ObsFrame),
            _P(CertifyResult),
        ],
    ),
    "mfns_certify_finish": (None, [_P(CertifyResult), _P(BeaconIndex)]),
    "mfns_certify_accumulate": (None, [_P(CertifyResult), _P(CertifyResult), _U32]),
    "mfns_certify_apply": (None, [_P(BeaconIndex), _P(CertifyResult)]),
    "mfns_certify_frame": (
        None,
        [_P(Rig), _P(BeaconMap), _P(BeaconIndex), _P(Pose), _P(ObsFrame), _P(Assoc)],
    ),
    # calibration table (caltable.h, caltable_host.h)
    "mfns_caltable_host_table_size": (_U32, []),
    "mfns_caltable_host_max_bytes": (_U32, []),
    "mfns_caltable_host_max_grid_nodes": (_U32, []),
    "mfns_caltable_host_max_beacons": (_U32, []),
    "mfns_caltable_load": (ct.c_int, [ct.c_char_p, ct.c_size_t, _VP, _P(_U32)]),
    "mfns_caltable_strerror": (ct.c_char_p, [ct.c_int]),
    # integrity: the inverse normal tail the flight's K_fa, K_md, K_ff come from
    "mfns_integrity_q_inv": (ct.c_float, [ct.c_float]),
    "mfns_caltable_host_grid_eval": (
        ct.c_int,
        [*[ct.c_uint16] * 2, *[ct.c_int32] * 4, _I32P, _U32, _I32P, _I32P, _I32P, _P(ct.c_uint8)],
    ),
    # telemetry and telecommand codecs (tlm_packets.h, tc_packets.h)
    "tlm_payload_len": (ct.c_size_t, [ct.c_int]),
    "tlm_type_apid": (ct.c_uint16, [ct.c_int]),
    "tlm_type_name": (ct.c_char_p, [ct.c_int]),
    "tc_opcode_name": (ct.c_char_p, [ct.c_uint8]),
    "tc_status_name": (ct.c_char_p, [ct.c_int]),
    "tc_arg_len": (ct.c_int, [ct.c_uint8]),
    "tc_packet_encode": (ct.c_int, [_P(TcCmd), ct.c_uint16, ct.c_char_p, ct.c_size_t, _P(ct.c_size_t)]),
    "tc_packet_decode": (ct.c_int, [ct.c_char_p, ct.c_size_t, _P(TcCmd)]),
}

# The headers that declare PROTOTYPES: binding_check.py compiles a call of each function
# with arguments of the types declared above, so a count or type that differs from its C
# prototype fails `make lib` (mfns_pose_covariance gained an argument once and the planner
# crashed through ctypes: nothing had compared the two).
PROTOTYPE_HEADERS = [
    "firmware/nav/integrity/integrity.h",
    "math/lens.h",
    "math/rotation.h",
    "math/undistort.h",
    "firmware/nav/pose/pose.h",
    "firmware/nav/pose/pose_internal.h",
    "firmware/nav/settings/nav_settings.h",
    "firmware/nav/acquire/acquire.h",
    "firmware/nav/acquire/acquire_cycle.h",
    "firmware/nav/map/beacon_index.h",
    "firmware/nav/table/caltable.h",
    "firmware/host/abi.h",
    "firmware/host/acquire_certify.h",
    "firmware/host/caltable_host.h",
    "firmware/host/beacon_index_build.h",
    "firmware/host/undist_grid_build.h",
    "firmware/host/plan_fix.h",
    "firmware/tlm/tc_packets.h",
    "firmware/tlm/generated/tlm_packets_gen.h",
]

_LOADED: dict[str, ct.CDLL] = {}


def lib_path(path: str | os.PathLike | None = None) -> Path:
    """The library to load (README "Installing the host tools" says the same), first found of:
    1. `path` when a caller gives one (tests, `mfns mc --lib`);
    2. the package's own mfns/libmfns_core.so (an installed wheel: `pip install ./host_tools`);
    3. $MFNS_CORE_LIB (an editable install pointed at another build);
    4. the tree's build/host-sim/lib/libmfns_core.so (`make lib`; an editable install).
    The package's own library comes before the variable: an installed wheel always runs the
    core it was built with, whatever the environment says."""
    if path:
        return Path(path)
    if PACKAGE_LIB.exists():
        return PACKAGE_LIB
    return Path(os.environ.get("MFNS_CORE_LIB") or DEFAULT_LIB)


def load(path: str | os.PathLike | None = None) -> ct.CDLL:
    """The C core with every prototype of PROTOTYPES declared and its struct sizes checked
    against this binding (once per library path). MfnsError when missing or mismatched."""
    p = lib_path(path)
    key = str(p.resolve()) if p.exists() else str(p)
    if key in _LOADED:
        return _LOADED[key]
    if not p.exists():
        raise MfnsError(
            f"{p}: no such library (in the repository run: make lib, or set MFNS_CORE_LIB; "
            "or install the wheel: pip install ./host_tools)"
        )
    L = ct.CDLL(str(p))
    for name, (restype, argtypes) in PROTOTYPES.items():
        f = getattr(L, name, None)
        if f is None:
            continue  # a library older or newer than the binding: the caller's AttributeError says which
        f.restype, f.argtypes = restype, argtypes
    for sizer, classes in ((L.mfns_pose_abi_size, POSE_ABI), (L.mfns_acq_abi_size, ACQ_ABI)):
        for i, cls in enumerate(classes):
            if cls is not None and sizer(i) != ct.sizeof(cls):
                raise MfnsError(f"{p}: {cls.__name__} is {sizer(i)} bytes in C, {ct.sizeof(cls)} here")
    _LOADED[key] = L
    return L
