"""The numpy camera model agrees with OpenCV and with its own inverse."""

import cv2
import numpy as np
import pytest

from mfns.analysis.calib_results import load
from mfns.model.camera import pose_from_position, position_from_pose, rig_from_doc
from mfns.model.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg


def paper_rig(repo_root):
    return rig_from_doc(load(repo_root / "host_tools/mfns/data/paper_calib.json"))


def test_projection_matches_opencv(repo_root):
    rng = np.random.default_rng(1)
    for cam in paper_rig(repo_root):
        p_c = np.column_stack(
            [rng.uniform(-250, 250, 200), rng.uniform(-200, 200, 200), rng.uniform(500, 900, 200)]
        )
        uv, front = cam.project_camera_points(p_c)
        assert front.all()
        ref, _ = cv2.projectPoints(p_c.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), cam.K, cam.dist)
        assert np.max(np.abs(uv - ref.reshape(-1, 2))) < 1e-9


def test_undistort_inverts_distort(repo_root):
    for cam in paper_rig(repo_root):
        u, v = np.meshgrid(np.linspace(-0.5, cam.width - 0.5, 33), np.linspace(-0.5, cam.height - 0.5, 27))
        uv = np.column_stack([u.ravel(), v.ravel()])
        xy = cam.undistort_pixels(uv)
        back = cam.distorted_to_pixel(cam.distort(xy))
        assert np.max(np.abs(back - uv)) < 1e-9


def test_rig_points_the_cameras_along_body_axes(repo_root):
    for cam, axis in zip(paper_rig(repo_root), np.eye(3), strict=True):
        assert cam.C_k_b @ np.array([0, 0, 1.0]) @ axis > 0.99


def test_pose_round_trip():
    c = euler213_deg_to_matrix([3.0, -20.0, 130.0])
    r = np.array([33.8, -128.9, 576.9])
    assert np.allclose(position_from_pose(c, pose_from_position(c, r)), r)
    assert np.allclose(matrix_to_euler213_deg(c), [3.0, -20.0, 130.0])


# --- the numpy lens model held to the C one (math/lens.h through mfns.core.binding) -------------
def _random_lens(rng):
    from mfns.model.camera import Camera

    w, h = int(rng.integers(320, 2600)), int(rng.integers(240, 2000))
    f = rng.uniform(300.0, 3000.0)
    dist = [
        rng.uniform(-0.5, 0.5),
        rng.uniform(-0.3, 0.3),
        rng.uniform(-5e-3, 5e-3),
        rng.uniform(-5e-3, 5e-3),
    ]
    dist.append(rng.uniform(-0.2, 0.2))
    cam = Camera(
        "x", f * rng.uniform(0.95, 1.05), f, w / 2 + rng.uniform(-40, 40), h / 2 + rng.uniform(-40, 40)
    )
    cam.skew, cam.dist, cam.width, cam.height = rng.uniform(-2.0, 2.0), np.array(dist), w, h
    # the C core holds binary32: both models get the same binary32 values
    for n in ("fx", "fy", "cx", "cy", "skew"):
        setattr(cam, n, float(np.float32(getattr(cam, n))))
    cam.dist = cam.dist.astype(np.float32).astype(float)
    return cam


def test_numpy_lens_model_matches_the_c_model_on_random_lenses_and_points(core_lib):
    """Camera.distort, project_camera_points and project_jacobian (double) against
    mfns_cam_distort and mfns_cam_project_c (binary32) on the same binary32 inputs, 200
    random lenses x 50 points within normalized radius 0.6. Tolerance: the C model's float
    rounding, a few float32 ulps (eps 1.2e-7) of each quantity's scale: 5e-7 relative on
    the distorted coordinates, 1e-6 of max(fx, cx, cy) on pixels (3000 px: 3e-3 px) and 1e-6
    of the largest entry on the Jacobian (measured: 1.0e-7, 1.8e-7, 2.8e-7)."""
    import ctypes as ct

    if not core_lib.exists():
        pytest.fail(f"{core_lib} missing: run make lib")
    from mfns.core.binding import V3, load
    from mfns.core.flight import Flight

    lib = load(core_lib)
    rng = np.random.default_rng(22)
    xd_c, yd_c = ct.c_float(), ct.c_float()
    uv_c, jac_c = (ct.c_float * 2)(), ((ct.c_float * 3) * 2)()
    worst = np.zeros(3)
    for _ in range(200):
        cam = _random_lens(rng)
        k = Flight.intrinsics(cam)
        r = np.sqrt(rng.uniform(0, 0.36, 50))
        a = rng.uniform(0, 2 * np.pi, 50)
        z = rng.uniform(100.0, 5000.0, 50)
        p_c = np.column_stack([r * np.cos(a) * z, r * np.sin(a) * z, z]).astype(np.float32).astype(float)
        xy = (p_c[:, :2] / p_c[:, 2:]).astype(np.float32).astype(float)
        xyd = cam.distort(xy)
        uv, front = cam.project_camera_points(p_c)
        uv_j, jac = cam.project_jacobian(p_c)
        assert front.all() and np.array_equal(uv, uv_j)
        for i in range(len(p_c)):
            lib.mfns_cam_distort(ct.byref(k), xy[i, 0], xy[i, 1], ct.byref(xd_c), ct.byref(yd_c), None)
            e = np.abs(np.array([xd_c.value, yd_c.value]) - xyd[i]) / max(1.0, np.abs(xyd[i]).max())
            worst[0] = max(worst[0], e.max())
            assert lib.mfns_cam_project_c(ct.byref(k), V3(*p_c[i]), ct.byref(uv_c), jac_c) == 0
            scale = max(abs(cam.fx), abs(cam.cx), abs(cam.cy))
            worst[1] = max(worst[1], np.abs(np.array(uv_c[:]) - uv[i]).max() / scale)
            jc = np.array([jac_c[0][:], jac_c[1][:]])
            worst[2] = max(worst[2], np.abs(jc - jac[i]).max() / np.abs(jac[i]).max())
    assert worst[0] < 5e-7 and worst[1] < 1e-6 and worst[2] < 1e-6, worst


def test_numpy_inverse_matches_the_c_iterative_inverse(core_lib):
    """Camera.undistort_pixels (double Newton) against mfns_undistort_iter (double Newton
    to 1e-6 px, float output) on random lenses and pixels: within 1e-6 relative (the
    float output's rounding and the C tolerance of 1e-6 px over f >= 300 px)."""
    import ctypes as ct

    if not core_lib.exists():
        pytest.fail(f"{core_lib} missing: run make lib")
    from mfns.core.binding import load
    from mfns.core.flight import Flight

    lib = load(core_lib)
    rng = np.random.default_rng(23)
    x, y, it = ct.c_float(), ct.c_float(), ct.c_int()
    checked = 0
    for _ in range(100):
        cam = _random_lens(rng)
        k = Flight.intrinsics(cam)
        xy_true = np.sqrt(rng.uniform(0, 0.25, 30))[:, None] * np.array([[1.0, 0.0]])
        a = rng.uniform(0, 2 * np.pi, 30)
        xy_true = np.column_stack([xy_true[:, 0] * np.cos(a), xy_true[:, 0] * np.sin(a)])
        uv = cam.normalized_to_pixel(xy_true).astype(np.float32).astype(float)
        xy = cam.undistort_pixels(uv)
        for i in range(len(uv)):
            if lib.mfns_undistort_iter(
                ct.byref(k), uv[i, 0], uv[i, 1], 50, ct.byref(x), ct.byref(y), ct.byref(it)
            ):
                continue  # the C inverse refuses (folded lens there): nothing to compare
            checked += 1
            assert np.abs(np.array([x.value, y.value]) - xy[i]).max() < 1e-6 * max(1.0, np.abs(xy[i]).max())
    assert checked > 2500
