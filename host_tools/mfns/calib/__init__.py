"""MFNS calibration: Zhang per camera, the paper's CPC (Appendix A) and a joint ML refinement.

model    -- board, turntable kinematic chain, observation containers (shared with the simulator)
dataset  -- the dataset folder of docs/calib-dataset.md (read/write, corner detection)
zhang    -- per-camera cv2.calibrateCamera with per-parameter standard deviations
cpc      -- the paper's checkerboard-fixed post-processing calibration (Eqs. A10-A18)
refine   -- maximum-likelihood refinement of everything through the kinematic chain, CRB
report   -- tables (paper vs refined vs truth vs CRB) and output files
"""
