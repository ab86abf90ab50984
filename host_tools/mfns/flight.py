"""The flight pose solver (firmware/nav/pose.h) from Python, through ctypes.

Host tools, tests and benchmarks call the same C code the navigation computer runs:
``make lib`` builds build/host-sim/lib/libmfns_core.so from the portable core. The
ctypes structures below mirror the C structs field by field; ``Flight()`` checks their
sizes against the library (mfns_pose_abi_size) and refuses a mismatched library.
"""

from __future__ import annotations

import ctypes as ct
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import MfnsError

REPO = Path(__file__).resolve().parents[2]
DEFAULT_LIB = REPO / "build" / "host-sim" / "lib" / "libmfns_core.so"

NUM_CAMERAS = 3
MAX_BEACONS = 64
MAX_OBS_PER_CAMERA = 32
NO_BEACON = -1

STATUS = {0: "OK", 1: "DEGRADED", 2: "NO_FIX"}
REASONS = (
    "NONE",
    "CAMERA_UNUSED",
    "OUTLIERS",
    "MINIMAL",
    "BAD_ARG",
    "TOO_FEW",
    "AMBIGUOUS",
    "NOT_IDENTIFIED",
    "SINGULAR",
    "NOT_CONVERGED",
    "RESIDUAL_HIGH",
    "TRACK_LOST",
)
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
        ("max_residual_rms_px", ct.c_float),
        ("track_gate_px", ct.c_float),
        ("max_hypotheses", ct.c_uint16),
        ("min_rcond", ct.c_float),
    ]


class PoseConfig(ct.Structure):
    _fields_ = [
        ("s", SolverSettings),
        ("sigma_px", ct.c_float),
        ("max_range_mm", ct.c_float),
        ("mode", ct.c_int),
    ]


class Obs(ct.Structure):
    _fields_ = [("u", ct.c_float), ("v", ct.c_float), ("x", ct.c_float), ("y", ct.c_float)]


class ObsFrame(ct.Structure):
    _fields_ = [
        ("count", ct.c_uint16 * NUM_CAMERAS),
        ("obs", (Obs * MAX_OBS_PER_CAMERA) * NUM_CAMERAS),
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
        ("cov", (ct.c_float * 6) * 6),
        ("sigma_pos_mm", ct.c_float * 3),
        ("sigma_euler_deg", ct.c_float * 3),
        ("beacons_used", ct.c_uint16),
        ("outliers", ct.c_uint16),
        ("cameras_used", ct.c_uint16),
        ("iterations", ct.c_uint16),
        ("hypotheses", ct.c_uint16),
        ("residual_rms_px", ct.c_float),
        ("assoc", Assoc),
        ("inlier", (ct.c_uint8 * MAX_OBS_PER_CAMERA) * NUM_CAMERAS),
    ]


_ABI = [Rig, BeaconMap, ObsFrame, Assoc, Pose, PoseConfig, SolutionC]


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
        L.mfns_pose_acquire.argtypes = [P(Rig), P(BeaconMap), P(ObsFrame), P(PoseConfig), P(SolutionC)]
        L.mfns_pose_solve.argtypes = [P(Rig), P(BeaconMap), P(ObsFrame), P(Pose), P(PoseConfig), P(SolutionC)]
        for f in (L.mfns_pose_refine, L.mfns_pose_track, L.mfns_pose_acquire, L.mfns_pose_solve):
            f.restype = ct.c_int
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
    def beacon_map(points, sigma_mm: float = 0.0) -> BeaconMap:
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        if len(pts) > MAX_BEACONS:
            raise MfnsError(f"{len(pts)} beacons: at most {MAX_BEACONS}")
        m = BeaconMap()
        m.count = len(pts)
        for i, p in enumerate(pts):
            m.beacon[i].id = i
            m.beacon[i].p_w = _v3(p)
            m.beacon[i].sigma_mm = sigma_mm
        return m

    def config(
        self, sigma_px: float = 0.1, max_range_mm: float = 3000.0, mode: int = MODE_ML, **settings
    ) -> PoseConfig:
        c = PoseConfig()
        self.lib.mfns_pose_config_default(ct.byref(c))
        c.sigma_px = sigma_px
        c.max_range_mm = max_range_mm
        c.mode = mode
        for k, v in settings.items():
            setattr(c.s, k, v)
        return c

    @staticmethod
    def frame(obs_per_camera) -> ObsFrame:
        """obs_per_camera: three arrays (N_k, 4) of [u, v, x, y]."""
        f = ObsFrame()
        for c, obs in enumerate(obs_per_camera):
            obs = np.asarray(obs, dtype=float).reshape(-1, 4)
            if len(obs) > MAX_OBS_PER_CAMERA:
                raise MfnsError(f"camera {c}: {len(obs)} observations, at most {MAX_OBS_PER_CAMERA}")
            f.count[c] = len(obs)
            for i, (u, v, x, y) in enumerate(obs):
                f.obs[c][i] = Obs(u, v, x, y)
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

    def acquire(self, rig, bmap, frame, cfg) -> Solution:
        s = SolutionC()
        self.lib.mfns_pose_acquire(ct.byref(rig), ct.byref(bmap), ct.byref(frame), ct.byref(cfg), ct.byref(s))
        return self._solution(s)

    def solve(self, rig, bmap, frame, prior: Pose | None, cfg) -> Solution:
        s = SolutionC()
        self.lib.mfns_pose_solve(
            ct.byref(rig),
            ct.byref(bmap),
            ct.byref(frame),
            ct.byref(prior) if prior is not None else None,
            ct.byref(cfg),
            ct.byref(s),
        )
        return self._solution(s)

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
        )
