"""The feasibility check: can the vehicle fly a reference? The policy (`policy`: which systems are checked before the
first step and what a problem refuses), the check along the reference (`trajectory_check`, its Newton steps and the
mission's samples in C: `trim_residual`, trim_newton.c, mission_samples.c) and the yaw a design holds (`yaw_margin`).
docs/test_bench.md."""
