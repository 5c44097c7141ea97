"""The physics library of tiltload, and the plant FMU built on it.

The 10-DOF Euler-Lagrange model of the UAV with its suspended load "from the load's perspective"
(thesis ch. 2) and of the UAV alone (Appendix A), written once in CasADi: kinematics, model,
parameters (Table 5.1), trim, linearization and ZOH. Every other part uses it: the sensors' measurement
model, the controller's design and feedforward, the formation's trackers; the plant FMU's C is
generated from it (codegen). The FMU itself: fmu_variables (its variable table), c/ (its hooks), build.
"""
