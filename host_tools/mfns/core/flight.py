"""The flight pose solver (firmware/nav/pose/pose.h) and acquisition (acquire.h, beacon_index.h)
from Python: numpy in, numpy out.

Host tools, tests and benchmarks call the same C code the navigation computer runs:
``make lib`` builds build/host-sim/lib/libmfns_core.so from the portable core. The ctypes
structures and prototypes are the binding's (binding.py: loaded in one place, held to the
headers field by field when the library is built); this module builds their inputs and
reads their outputs.
"""

from __future__ import annotations

import ctypes as ct
import os
from dataclasses import dataclass, field

import numpy as np

from ..tlm import tlm_dict
from .binding import (  # noqa: F401 (re-exported: the names host tools use)
    ACQ_ABI_CYCLE,
    ACQ_ABI_STATE,
    ACQ_SOURCES,
    CALIB_PARAMS,
    CALIB_PARAMS_PER_CAMERA,
    M3,
    MAX_BEACONS,
    MAX_CERT,
    MAX_MEAS,
    MAX_MISSING,
    MAX_NBR,
    MAX_OBS_PER_CAMERA,
    MAX_PAIRS,
    NO_BEACON,
    NUM_CAMERAS,
    POSE_DEGRADED,
    POSE_NO_FIX,
    POSE_OK,
    V3,
    AcqCycleReport,
    AcqProgress,
    Assoc,
    Beacon,
    BeaconEmit,
    BeaconGeom,
    BeaconIndex,
    BeaconMap,
    BidxParams,
    CalibCov,
    CameraC,
    CentroidSettings,
    CertifyCase,
    CertifyResult,
    Euler,
    Intrinsics,
    Obs,
    ObsFrame,
    Pose,
    PoseConfig,
    Rig,
    SolutionC,
    SolverSettings,
)
from .binding import load as load_core
from .errors import MfnsError

STATUS = {POSE_OK: "OK", POSE_DEGRADED: "DEGRADED", POSE_NO_FIX: "NO_FIX"}  # pose.h, checked at build
# Reason code -> name: the numbered wire codes of the telemetry dictionary (contract/mfns_tm.xml,
# which tests/host/test_tlm_mdb.py holds to pose.h mfns_pose_reason_t).
REASONS = tlm_dict.reason_names()
MODE_ML, MODE_PAPER = 0, 1


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
    """The C pose solver. lib: path of libmfns_core.so (default: binding.lib_path's order)."""

    def __init__(self, lib: str | os.PathLike | None = None):
        self.lib = L = load_core(lib)  # prototypes declared and sizes checked there (binding.py)
        self._acq_state = (ct.c_uint8 * L.mfns_acq_abi_size(ACQ_ABI_STATE))()
        self._acq_cycle_state = (ct.c_uint8 * L.mfns_acq_abi_size(ACQ_ABI_CYCLE))()
        L.mfns_acq_cycle_reset(self._acq_cycle_state)

    # --- building the C inputs -------------------------------------------------------
    @staticmethod
    def rig(cameras) -> Rig:
        """From three mfns.model.camera.Camera (x, y, z)."""
        r = Rig()
        for i, c in enumerate(cameras):
            r.cam[i].k = Flight.intrinsics(c)
            r.cam[i].C_k_b = _m3(c.C_k_b)
            r.cam[i].r_bk_b = _v3(c.r_bk_b)
        return r

    @staticmethod
    def intrinsics(c) -> Intrinsics:
        """The lens of one mfns.model.camera.Camera as the C core holds it (binary32)."""
        k = Intrinsics()
        k.fx, k.fy, k.cx, k.cy, k.skew = c.fx, c.fy, c.cx, c.cy, c.skew
        for j in range(5):
            k.dist[j] = float(c.dist[j])
        k.width, k.height = int(c.width), int(c.height)
        return k

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
        """(centroid, solver) defaults of the C core (nav_defaults_gen.c): the one set."""
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
        (nav_settings.h order); the config keeps the C copy alive."""
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
        return Progress(**{n: getattr(pr, n) for n, *_ in AcqProgress._fields_})

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
