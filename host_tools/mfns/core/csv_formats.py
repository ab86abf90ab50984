"""The columns of the CSV files the host tools write and read, each written once here.

POSE_COLUMNS    a pose: the body origin in the world frame (mm) and the 2-1-3 Euler angles (deg),
                named alike in truth.csv, nav.csv (mfns-ground) and `mfns plan`'s samples.csv
TRUTH_HEADER    truth.csv of `mfns sim nav` (docs/nav-frames.md): frame, time, the true pose
BEACON_COLUMNS  beacons.csv, the beacon map: id, position in the world frame (mm), survey 1-sigma
                (`mfns sim nav`, `mfns plan`, `mfns map refine` write it; model.camera reads it)
SIGMA_COLUMNS   nav.csv's reported 1-sigma per pose axis, in POSE_COLUMNS order
COV_AXES, COV_PAIRS, COV_COLUMNS
                nav.csv's 21 covariance columns: the upper triangle, row-major, over COV_AXES
                (docs/telemetry.md)

The nav.csv names are those mfns-ground writes (ground/); tests/host check the files from
outside with their own literal names. Standard library only: every module may import it.
"""

from __future__ import annotations

POSE_COLUMNS = ("x_mm", "y_mm", "z_mm", "roll_deg", "pitch_deg", "yaw_deg")
POSITION_COLUMNS = POSE_COLUMNS[:3]
TRUTH_HEADER = ["frame", "t_s", *POSE_COLUMNS]
BEACON_COLUMNS = ("id", *POSITION_COLUMNS, "sigma_mm")
SIGMA_COLUMNS = tuple(f"sigma_{c}" for c in POSE_COLUMNS)
COV_AXES = ("x", "y", "z", "rx", "ry", "rz")
# Upper triangle, row-major: cov_x_x, cov_x_y, ..., cov_x_rz, cov_y_y, ..., cov_rz_rz.
COV_PAIRS = tuple((i, j) for i in range(len(COV_AXES)) for j in range(i, len(COV_AXES)))
COV_COLUMNS = tuple(f"cov_{COV_AXES[i]}_{COV_AXES[j]}" for i, j in COV_PAIRS)
