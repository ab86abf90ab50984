"""The numpy camera model agrees with OpenCV and with its own inverse."""

import cv2
import numpy as np

from mfns.calib_results import load
from mfns.camera import pose_from_position, position_from_pose, rig_from_doc
from mfns.rotations import euler213_deg_to_matrix, matrix_to_euler213_deg


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
