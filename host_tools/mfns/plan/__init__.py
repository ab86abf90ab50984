"""`mfns plan`: beacon-layout planning (docs/planning.md).

Modules, one job each:
  workspace  pose samples (the turntable sweep, the module, a box)
  core       the C core's projection, visibility and covariance mapping (ctypes)
  crlb       the Cramer-Rao bound: pixel noise, survey error, calibration error
  analyze    per-sample in-view counts, fix, 1-sigma
  ident      the identification-margin plug (issue 11's map analysis)
  surfaces   candidate surfaces, keep-out zones, the candidate grid
  optimize   greedy construction + simulated annealing
  report     CSV, summary, plots
  run        the command-line actions
"""
