"""The flight pose solver (firmware/nav/pose.h) and acquisition (acquire.h, beacon_index.h)
from Python, through ctypes.

Host tools, tests and benchmarks call the same C code the navigation computer runs:
``make lib`` builds build/host-sim/lib/libmfns_core.so from the portable core. The
ctypes structures below mirror the C structs field by field; ``Flight()`` checks their
sizes against the library (mfns_pose_abi_size) and refuses a mismatched library.
"""

from __future__ import annotations

import ctypes as ct
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import tlm_dict
from .errors import MfnsError

REPO = Path(__file__).resolve().parents[2]
DEFAULT_LIB = REPO / "build" / "host-sim" / "lib" / "libmfns_core.so"

NUM_CAMERAS = 3
MAX_BEACONS = 256
MAX_NBR = 32
MAX_PAIRS = MAX_BEACONS * (MAX_BEACONS - 1) // 2
MAX_MEAS = 3 * 32
MAX_CERT = 16
MAX_MISSING = 3
MAX_OBS_PER_CAMERA = 32
NO_BEACON = -1

STATUS = {0: "OK", 1: "DEGRADED", 2: "NO_FIX"}
# Reason code -> name: the numbered wire codes of the telemetry dictionary (ground/mdb/mfns_tm.xml,
# which tests/host/test_tlm_mdb.py holds to pose.h mfns_pose_reason_t).
REASONS = tlm_dict.reason_names()
MODE_ML, MODE_PAPER = 0, 1


class V3(ct.Structure):
    _fields_ = [("x", ct.c_float), ("y", ct.c_float), ("z", ct.c_float)]


class M3(ct.Structure):
    _fields_ = [("m", (ct.c_float * 3) * 3)]


class Intrinsics(ct.Structure):
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
    _fields_ = [("k", Intrinsics), ("C_k_b", M3), ("r_bk_b", V3)]


class Rig(ct.Structure):
    _fields_ = [("cam", CameraC * NUM_CAMERAS)]


class Pose(ct.Structure):
    _fields_ = [("C_w_b", M3), ("r_bw_b", V3)]


class Beacon(ct.Structure):
    _fields_ = [("id", ct.c_uint16), ("p_w", V3), ("sigma_mm", ct.c_float)]


class BeaconMap(ct.Structure):
    _fields_ = [("count", ct.c_uint16), ("beacon", Beacon * MAX_BEACONS)]


class SolverSettings(ct.Structure):
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


CALIB_PARAMS_PER_CAMERA = 15  # nav_config.h mfns_calib_param_t (fx fy cx cy k1 k2 p1 p2 k3 theta r)
CALIB_PARAMS = NUM_CAMERAS * CALIB_PARAMS_PER_CAMERA


class CalibCov(ct.Structure):
    """mfns_calib_cov_t (nav_config.h): the calibration's covariance, 45 x 45."""

    _fields_ = [("present", ct.c_uint8), ("cov", (ct.c_float * CALIB_PARAMS) * CALIB_PARAMS)]


class PoseConfig(ct.Structure):
    _fields_ = [
        ("s", SolverSettings),
        ("sigma_px", ct.c_float),
        ("mode", ct.c_int),
        ("calib_cov", ct.POINTER(CalibCov)),
    ]


class Obs(ct.Structure):
    _fields_ = [
        ("u", ct.c_float),
        ("v", ct.c_float),
        ("x", ct.c_float),
        ("y", ct.c_float),
        ("cov_px2", ct.c_float * 3),
    ]


class ObsFrame(ct.Structure):
    _fields_ = [
        ("count", ct.c_uint16 * NUM_CAMERAS),
        ("obs", (Obs * MAX_OBS_PER_CAMERA) * NUM_CAMERAS),
        ("dark", ct.c_uint8 * NUM_CAMERAS),
    ]


class Assoc(ct.Structure):
    _fields_ = [("beacon", (ct.c_int16 * MAX_OBS_PER_CAMERA) * NUM_CAMERAS)]


class Euler(ct.Structure):
    _fields_ = [("roll", ct.c_float), ("pitch", ct.c_float), ("yaw", ct.c_float)]


class SolutionC(ct.Structure):
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


class CentroidSettings(ct.Structure):
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


class BeaconEmit(ct.Structure):
    _fields_ = [("axis_w", V3), ("cos_half_angle", ct.c_float)]


class BeaconGeom(ct.Structure):
    _fields_ = [("emit", BeaconEmit), ("range_min_mm", ct.c_float), ("range_max_mm", ct.c_float)]


class BeaconIndex(ct.Structure):
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
    _fields_ = [
        ("k_nbr", ct.c_uint8),
        ("cert_inliers", ct.c_uint8),
        ("max_missing", ct.c_uint8),
        ("max_unexplained", ct.c_uint8),
        ("budget_units", ct.c_uint32),
    ]


class AcqProgress(ct.Structure):
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
    _fields_ = [
        ("progress", AcqProgress),
        ("carried_units", ct.c_uint32),
        ("carry_age", ct.c_uint16),
        ("source", ct.c_uint8),
        ("carry_dropped", ct.c_bool),
        ("bridge_refused", ct.c_bool),
    ]


# mfns_acq_source_t (acquire_cycle.h)
ACQ_SOURCES = ("NONE", "FRESH", "CARRIED")


class CertifyCase(ct.Structure):
    _fields_ = [
        ("sample", ct.c_uint32),
        ("n_blobs", ct.c_uint16),
        ("rival_inliers", ct.c_uint16),
        ("rival_missing", ct.c_uint16),
        ("truth_id", ct.c_uint16 * MAX_MEAS),
        ("rival_id", ct.c_int32 * MAX_MEAS),
    ]


class CertifyResult(ct.Structure):
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


_ABI = [Rig, BeaconMap, ObsFrame, Assoc, Pose, PoseConfig, SolutionC]
# mfns_acq_abi_size order (acquire.h); the state itself is opaque here (a byte buffer).
_ACQ_ABI = [None, AcqProgress, BeaconIndex, BeaconEmit, BidxParams, CertifyResult]
_ACQ_ABI_CYCLE = len(_ACQ_ABI)  # mfns_acq_cycle_t: opaque too


@dataclass
class Progress:
    """Where an acquisition stopped (mfns_acq_progress_t)."""

    units: int
    units_total: int
    calls: int
    hypotheses: int
    verified: int
    anchors: int
    band: int
    best_inliers: int
    best_missing: int
    finished: bool
    budget_out: bool
    certified: bool
    completed: bool
    rivals: int


@dataclass
class Solution:
    status: str
    reason: str
    C_w_b: np.ndarray  # (3, 3)
    r_bw_b: np.ndarray  # (3,) mm
    r_wb_w: np.ndarray  # (3,) mm
    euler_deg: np.ndarray  # roll, pitch, yaw
    cov: np.ndarray  # (6, 6), increment (dtheta rad, dt mm)
    sigma_pos_mm: np.ndarray
    sigma_euler_deg: np.ndarray
    beacons_used: int
    outliers: int
    cameras_used: int
    iterations: int
    hypotheses: int
    residual_rms_px: float
    assoc: np.ndarray  # (3, 32) beacon index per observation, -1 none
    inlier: np.ndarray  # (3, 32) bool
    # ROS order (r_wb_w mm, phi_w rad about world axes), pose.h
    cov_ros: np.ndarray = field(default_factory=lambda: np.zeros((6, 6)))
    residual_rms_sigma: float = float("nan")  # whitened RMS per coordinate
    q_b_w: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))

    @property
    def ok(self) -> bool:
        return self.status != "NO_FIX"


def _m3(a) -> M3:
    m = M3()
    for i in range(3):
        for j in range(3):
            m.m[i][j] = float(a[i][j])
    return m


def _v3(a) -> V3:
    return V3(float(a[0]), float(a[1]), float(a[2]))


class Flight:
    """The C pose solver. lib: path of libmfns_core.so (default: $MFNS_CORE_LIB or the build)."""

    def __init__(self, lib: str | os.PathLike | None = None):
        path = Path(lib or os.environ.get("MFNS_CORE_LIB", DEFAULT_LIB))
        if not path.exists():
            raise MfnsError(f"{path}: no such library (run: make lib)")
        self.lib = ct.CDLL(str(path))
        L = self.lib
        L.mfns_pose_abi_size.restype = ct.c_uint32
        L.mfns_pose_abi_size.argtypes = [ct.c_int]
        for i, cls in enumerate(_ABI):
            if L.mfns_pose_abi_size(i) != ct.sizeof(cls):
                raise MfnsError(
                    f"{path}: {cls.__name__} is {L.mfns_pose_abi_size(i)} bytes in C, {ct.sizeof(cls)} here"
                )
        P = ct.POINTER
        L.mfns_pose_config_default.argtypes = [P(PoseConfig)]
        L.mfns_pose_config_default.restype = None
        L.mfns_pose_refine.argtypes = [
            P(Rig),
            P(BeaconMap),
            P(ObsFrame),
            P(Assoc),
            P(Pose),
            P(PoseConfig),
            P(SolutionC),
        ]
        L.mfns_pose_track.argtypes = [P(Rig), P(BeaconMap), P(ObsFrame), P(Pose), P(PoseConfig), P(SolutionC)]
        for f in (L.mfns_pose_refine, L.mfns_pose_track):
            f.restype = ct.c_int
        L.mfns_acq_abi_size.restype = ct.c_uint32
        L.mfns_acq_abi_size.argtypes = [ct.c_int]
        for i, cls in enumerate(_ACQ_ABI):
            if cls is not None and L.mfns_acq_abi_size(i) != ct.sizeof(cls):
                raise MfnsError(
                    f"{path}: {cls.__name__} is {L.mfns_acq_abi_size(i)} bytes in C, {ct.sizeof(cls)} here"
                )
        self._acq_state = (ct.c_uint8 * L.mfns_acq_abi_size(0))()
        L.mfns_acquire.argtypes = [
            ct.c_void_p,
            P(Rig),
            P(BeaconMap),
            P(BeaconIndex),
            P(ObsFrame),
            P(PoseConfig),
            ct.c_uint32,
            P(SolutionC),
        ]
        L.mfns_acquire.restype = ct.c_int
        L.mfns_acq_resume.argtypes = [ct.c_void_p, ct.c_uint32, P(SolutionC)]
        L.mfns_acq_resume.restype = ct.c_int
        L.mfns_acq_pending.argtypes = [ct.c_void_p]
        L.mfns_acq_pending.restype = ct.c_bool
        self._acq_cycle_state = (ct.c_uint8 * L.mfns_acq_abi_size(_ACQ_ABI_CYCLE))()
        L.mfns_acq_cycle_reset.argtypes = [ct.c_void_p]
        L.mfns_acq_cycle_reset.restype = None
        L.mfns_acq_cycle_reset(self._acq_cycle_state)
        L.mfns_acq_cycle_run.argtypes = [
            ct.c_void_p,
            P(Rig),
            P(BeaconMap),
            P(BeaconIndex),
            P(ObsFrame),
            P(PoseConfig),
            ct.c_uint32,
            P(SolutionC),
            P(AcqCycleReport),
        ]
        L.mfns_acq_cycle_run.restype = ct.c_int
        L.mfns_bidx_params_default.argtypes = [P(BidxParams)]
        L.mfns_bidx_params_default.restype = None
        L.mfns_bidx_build.argtypes = [
            P(Rig),
            P(BeaconMap),
            P(BeaconEmit),
            V3,
            V3,
            P(BidxParams),
            P(BeaconIndex),
        ]
        L.mfns_bidx_build.restype = ct.c_int
        L.mfns_bidx_encode.argtypes = [P(BeaconIndex), ct.c_void_p, ct.c_uint32, P(ct.c_uint32)]
        L.mfns_bidx_encode.restype = ct.c_int
        L.mfns_bidx_section_size.argtypes = [ct.c_uint32, ct.c_uint32]
        L.mfns_bidx_section_size.restype = ct.c_uint32
        L.mfns_bidx_strerror.argtypes = [ct.c_int]
        L.mfns_bidx_strerror.restype = ct.c_char_p
        L.mfns_certify.argtypes = [
            ct.c_void_p,
            P(Rig),
            P(BeaconMap),
            P(BeaconIndex),
            P(PoseConfig),
            P(Pose),
            ct.c_uint32,
            ct.c_uint32,
            P(ObsFrame),
            P(CertifyResult),
        ]
        L.mfns_certify.restype = ct.c_int
        L.mfns_certify_finish.argtypes = [P(CertifyResult), P(BeaconIndex)]
        L.mfns_certify_accumulate.argtypes = [P(CertifyResult), P(CertifyResult), ct.c_uint32]
        L.mfns_certify_apply.argtypes = [P(BeaconIndex), P(CertifyResult)]
        for f in (L.mfns_certify_finish, L.mfns_certify_accumulate, L.mfns_certify_apply):
            f.restype = None
        L.mfns_certify_frame.argtypes = [P(Rig), P(BeaconMap), P(BeaconIndex), P(Pose), P(ObsFrame), P(Assoc)]
        L.mfns_certify_frame.restype = None
        L.mfns_centroid_settings_default.argtypes = [P(CentroidSettings)]
        L.mfns_centroid_settings_default.restype = None
        L.mfns_solver_settings_default.argtypes = [P(SolverSettings)]
        L.mfns_solver_settings_default.restype = None
        L.mfns_pose_strerror.argtypes = [ct.c_int]
        L.mfns_pose_strerror.restype = ct.c_char_p

    # --- building the C inputs -------------------------------------------------------
    @staticmethod
    def rig(cameras) -> Rig:
        """From three mfns.camera.Camera (x, y, z)."""
        r = Rig()
        for i, c in enumerate(cameras):
            k = r.cam[i].k
            k.fx, k.fy, k.cx, k.cy, k.skew = c.fx, c.fy, c.cx, c.cy, c.skew
            for j in range(5):
                k.dist[j] = float(c.dist[j])
            k.width, k.height = int(c.width), int(c.height)
            r.cam[i].C_k_b = _m3(c.C_k_b)
            r.cam[i].r_bk_b = _v3(c.r_bk_b)
        return r

    @staticmethod
    def beacon_map(points, sigma_mm=0.0, ids=None) -> BeaconMap:
        """sigma_mm: one value or one per beacon; ids: survey ids (default 0..N-1)."""
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        if len(pts) > MAX_BEACONS:
            raise MfnsError(f"{len(pts)} beacons: at most {MAX_BEACONS}")
        sig = np.broadcast_to(np.asarray(sigma_mm, dtype=float), (len(pts),))
        m = BeaconMap()
        m.count = len(pts)
        for i, p in enumerate(pts):
            m.beacon[i].id = int(ids[i]) if ids is not None else i
            m.beacon[i].p_w = _v3(p)
            m.beacon[i].sigma_mm = float(sig[i])
        return m

    def default_settings(self) -> tuple[dict, dict]:
        """(centroid, solver) defaults of the C core (nav_defaults.c): the one set."""
        c, s = CentroidSettings(), SolverSettings()
        self.lib.mfns_centroid_settings_default(ct.byref(c))
        self.lib.mfns_solver_settings_default(ct.byref(s))
        as_py = lambda st: {  # noqa: E731
            n: (int(getattr(st, n)) if t is not ct.c_float else float(np.float32(getattr(st, n))))
            for n, t in st._fields_
        }
        return as_py(c), as_py(s)

    def index_params(self, **over) -> BidxParams:
        p = BidxParams()
        self.lib.mfns_bidx_params_default(ct.byref(p))
        for k, v in over.items():
            setattr(p, k, v)
        return p

    def build_index(
        self, rig, bmap, ws_min, ws_max, emit=None, params: BidxParams | None = None
    ) -> BeaconIndex:
        """The map index (beacon_index.h). emit: None or (axes (N, 3), cos_half_angle (N,))."""
        idx = BeaconIndex()
        em = None
        if emit is not None:
            axes, cosines = emit
            arr = (BeaconEmit * MAX_BEACONS)()
            for i in range(bmap.count):
                arr[i] = BeaconEmit(_v3(axes[i]), float(cosines[i]))
            em = arr
        st = self.lib.mfns_bidx_build(
            ct.byref(rig),
            ct.byref(bmap),
            em,
            _v3(ws_min),
            _v3(ws_max),
            ct.byref(params or self.index_params()),
            ct.byref(idx),
        )
        if st != 0:
            raise MfnsError(self.lib.mfns_bidx_strerror(st).decode())
        return idx

    def encode_index(self, idx: BeaconIndex) -> bytes:
        buf = (ct.c_uint8 * self.lib.mfns_bidx_section_size(idx.count, idx.k_nbr))()
        n = ct.c_uint32(0)
        st = self.lib.mfns_bidx_encode(ct.byref(idx), buf, len(buf), ct.byref(n))
        if st != 0:
            raise MfnsError(self.lib.mfns_bidx_strerror(st).decode())
        return bytes(buf[: n.value])

    def certify(self, rig, bmap, idx, cfg, poses, budget_per_pose: int) -> CertifyResult:
        """The map analysis (acquire_certify.h) over poses: a list of Pose."""
        arr = (Pose * max(1, len(poses)))(*poses)
        res = CertifyResult()
        frame = ObsFrame()
        st = self.lib.mfns_certify(
            self._acq_state,
            ct.byref(rig),
            ct.byref(bmap),
            ct.byref(idx),
            ct.byref(cfg),
            arr,
            len(poses),
            int(budget_per_pose),
            ct.byref(frame),
            ct.byref(res),
        )
        if st != 0:
            raise MfnsError(self.lib.mfns_bidx_strerror(st).decode())
        return res

    def certify_accumulate(self, total: CertifyResult, part: CertifyResult, first_sample: int) -> None:
        self.lib.mfns_certify_accumulate(ct.byref(total), ct.byref(part), int(first_sample))

    def certify_finish(self, res: CertifyResult, idx) -> None:
        self.lib.mfns_certify_finish(ct.byref(res), ct.byref(idx))

    def certify_apply(self, idx, res: CertifyResult) -> None:
        self.lib.mfns_certify_apply(ct.byref(idx), ct.byref(res))

    def view(self, rig, bmap, idx, pose: Pose) -> tuple[ObsFrame, Assoc]:
        """The noise-free frame the rig sees from pose, and its true association."""
        f, a = ObsFrame(), Assoc()
        self.lib.mfns_certify_frame(
            ct.byref(rig), ct.byref(bmap), ct.byref(idx), ct.byref(pose), ct.byref(f), ct.byref(a)
        )
        return f, a

    def config(self, sigma_px: float = 0.1, mode: int = MODE_ML, calib_cov=None, **settings) -> PoseConfig:
        """calib_cov: None (no calibration term) or the (45, 45) covariance of the calibration
        (nav_config.h order); the config keeps the C copy alive."""
        c = PoseConfig()
        self.lib.mfns_pose_config_default(ct.byref(c))
        c.sigma_px = sigma_px
        c.mode = mode
        if calib_cov is not None:
            cc = self.calib_cov(calib_cov)
            c.calib_cov = ct.pointer(cc)
            c._calib_keep = cc  # ctypes pointers do not own their target
        for k, v in settings.items():
            setattr(c.s, k, v)
        return c

    @staticmethod
    def calib_cov(cov) -> CalibCov:
        a = np.asarray(cov, dtype=float)
        if a.shape != (CALIB_PARAMS, CALIB_PARAMS) or not np.all(np.isfinite(a)):
            raise MfnsError(
                f"calibration covariance: expected finite ({CALIB_PARAMS}, {CALIB_PARAMS}), got {a.shape}"
            )
        cc = CalibCov()
        cc.present = 1
        np.ctypeslib.as_array(cc.cov)[:] = a.astype(np.float32)
        return cc

    @staticmethod
    def frame(obs_per_camera) -> ObsFrame:
        """obs_per_camera: three arrays (N_k, 4) of [u, v, x, y], or (N_k, 7) with the
        centroid covariance [var u, cov uv, var v] (px^2) after them."""
        f = ObsFrame()
        for c, obs in enumerate(obs_per_camera):
            obs = np.asarray(obs, dtype=float)
            obs = obs.reshape(-1, obs.shape[-1] if obs.ndim == 2 and obs.shape[-1] == 7 else 4)
            if len(obs) > MAX_OBS_PER_CAMERA:
                raise MfnsError(f"camera {c}: {len(obs)} observations, at most {MAX_OBS_PER_CAMERA}")
            f.count[c] = len(obs)
            for i, row in enumerate(obs):
                o = Obs(*row[:4])
                if len(row) == 7:
                    o.cov_px2[0], o.cov_px2[1], o.cov_px2[2] = (float(v) for v in row[4:7])
                f.obs[c][i] = o
        return f

    @staticmethod
    def assoc(beacons_per_camera) -> Assoc:
        a = Assoc()
        for c in range(NUM_CAMERAS):
            for i in range(MAX_OBS_PER_CAMERA):
                a.beacon[c][i] = NO_BEACON
        for c, ids in enumerate(beacons_per_camera):
            for i, b in enumerate(ids):
                a.beacon[c][i] = int(b)
        return a

    @staticmethod
    def pose(C_w_b, r_bw_b) -> Pose:
        return Pose(_m3(C_w_b), _v3(r_bw_b))

    # --- calls ------------------------------------------------------------------------
    def refine(self, rig, bmap, frame, assoc, init: Pose, cfg) -> Solution:
        s = SolutionC()
        self.lib.mfns_pose_refine(
            ct.byref(rig),
            ct.byref(bmap),
            ct.byref(frame),
            ct.byref(assoc),
            ct.byref(init),
            ct.byref(cfg),
            ct.byref(s),
        )
        return self._solution(s)

    def track(self, rig, bmap, frame, predicted: Pose, cfg) -> Solution:
        s = SolutionC()
        self.lib.mfns_pose_track(
            ct.byref(rig), ct.byref(bmap), ct.byref(frame), ct.byref(predicted), ct.byref(cfg), ct.byref(s)
        )
        return self._solution(s)

    def acquire(
        self, rig, bmap, idx, frame, cfg, budget_units: int | None = None
    ) -> tuple[Solution, Progress]:
        """Lost-in-space acquisition (acquire.h) within budget_units (default: the index's)."""
        s = SolutionC()
        budget = idx.budget_units if budget_units is None else int(budget_units)
        self.lib.mfns_acquire(
            self._acq_state,
            ct.byref(rig),
            ct.byref(bmap),
            ct.byref(idx),
            ct.byref(frame),
            ct.byref(cfg),
            budget,
            ct.byref(s),
        )
        return self._solution(s), self._acq_progress()

    def _acq_progress(self) -> Progress:
        pr = AcqProgress.from_buffer(self._acq_state)
        return Progress(**{n: getattr(pr, n) for n, _ in AcqProgress._fields_})

    def acquire_resume(self, budget_units: int) -> tuple[Solution, Progress]:
        """Go on with the search the last acquire (or resume) left on its budget (acquire.h)."""
        s = SolutionC()
        self.lib.mfns_acq_resume(self._acq_state, int(budget_units), ct.byref(s))
        return self._solution(s), self._acq_progress()

    def acquire_pending(self) -> bool:
        return bool(self.lib.mfns_acq_pending(self._acq_state))

    def acq_cycle_reset(self) -> None:
        """Forget any carried search (acquire_cycle.h)."""
        self.lib.mfns_acq_cycle_reset(self._acq_cycle_state)

    def acq_cycle(self, rig, bmap, idx, frame, cfg, budget_units: int | None = None):
        """One navigation cycle's acquisition (acquire_cycle.h): a fresh search of frame and
        the carried one -> (Solution, report with progress, carried_units, carry_age, source)."""
        s = SolutionC()
        rep = AcqCycleReport()
        budget = idx.budget_units if budget_units is None else int(budget_units)
        self.lib.mfns_acq_cycle_run(
            self._acq_cycle_state,
            ct.byref(rig),
            ct.byref(bmap),
            ct.byref(idx),
            ct.byref(frame),
            ct.byref(cfg),
            budget,
            ct.byref(s),
            ct.byref(rep),
        )
        return self._solution(s), rep

    def strerror(self, reason: str | int) -> str:
        code = REASONS.index(reason) if isinstance(reason, str) else int(reason)
        return self.lib.mfns_pose_strerror(code).decode()

    @staticmethod
    def _solution(s: SolutionC) -> Solution:
        return Solution(
            status=STATUS.get(s.status, f"?{s.status}"),
            reason=REASONS[s.reason] if 0 <= s.reason < len(REASONS) else f"?{s.reason}",
            C_w_b=np.array([[s.pose.C_w_b.m[i][j] for j in range(3)] for i in range(3)], dtype=float),
            r_bw_b=np.array([s.pose.r_bw_b.x, s.pose.r_bw_b.y, s.pose.r_bw_b.z], dtype=float),
            r_wb_w=np.array([s.r_wb_w.x, s.r_wb_w.y, s.r_wb_w.z], dtype=float),
            euler_deg=np.array([s.euler_deg.roll, s.euler_deg.pitch, s.euler_deg.yaw], dtype=float),
            cov=np.ctypeslib.as_array(s.cov).astype(float).copy(),
            sigma_pos_mm=np.array(list(s.sigma_pos_mm), dtype=float),
            sigma_euler_deg=np.array(list(s.sigma_euler_deg), dtype=float),
            beacons_used=s.beacons_used,
            outliers=s.outliers,
            cameras_used=s.cameras_used,
            iterations=s.iterations,
            hypotheses=s.hypotheses,
            residual_rms_px=float(s.residual_rms_px),
            assoc=np.ctypeslib.as_array(s.assoc.beacon).astype(int).copy(),
            inlier=np.ctypeslib.as_array(s.inlier).astype(bool).copy(),
            cov_ros=np.ctypeslib.as_array(s.cov_ros).astype(float).copy(),
            residual_rms_sigma=float(s.residual_rms_sigma),
            q_b_w=np.array(list(s.q_b_w), dtype=float),
        )
