"""The sensor suites of the thesis: with the load (Sec. 5.3, Table 5.8) and of the UAV alone
(Appendix A, Table A.1): their groups, periods, noise bounds and distributions.

This table is the one definition of the suite: the sensor FMU's variables and its C group table
are generated from it, and the controller reads the channel names from it. Each group samples
every `period` (a whole number of ticks), adds noise from its own counter-based stream (seeded
by the suite seed and the group's index: changing one sensor never changes another's noise),
raises its `new` flag for that tick and holds the sample in between. Gaussian bounds are
3 sigma (Table 5.8); uniform noise is uniform on [-bound, bound].
"""

from __future__ import annotations

from dataclasses import dataclass

PDFS = ("gaussian", "uniform")
ZSE_NAMES = ("x_B", "y_B", "z_B", "phi_B", "theta_B", "psi_B", "p_B", "q_B", "r_B",
             "d_BL_x", "d_BL_y", "d_BL_z", "alpha_R", "alpha_L", "alpha_R_dot", "alpha_L_dot")


@dataclass(frozen=True)
class Group:
    name: str
    source: str  # "q" (LKF scenario) or "pi" (ZSE scenario)
    indices: tuple[int, ...]  # entries of q or of pi(x)
    period: float
    bound: float | tuple[float, ...]  # one per entry, or one for all
    pdf: str
    unit: str  # of the pi channels; q channels take their state's unit

    @property
    def bounds(self) -> tuple[float, ...]:
        return self.bound if isinstance(self.bound, tuple) else (self.bound,)


# (name, source, indices, period s, bound, pdf, unit): Sec. 5.3 and Table 5.8
GROUPS = (
    Group("lkf", "q", tuple(range(10)), 0.012, (0.15,) * 3 + (0.0,) * 7, "gaussian", ""),
    Group("gps", "pi", (0, 1), 0.120, 0.15, "gaussian", "m"),
    Group("baro", "pi", (2,), 0.012, 0.51, "gaussian", "m"),
    Group("imu_att", "pi", (3, 4, 5), 0.012, 2.618e-3, "gaussian", "rad"),
    Group("imu_rate", "pi", (6, 7, 8), 0.012, 16.558e-3, "gaussian", "rad/s"),
    Group("cam_xy", "pi", (9, 10), 0.024, 0.005, "uniform", "m"),
    Group("cam_z", "pi", (11,), 0.024, 0.02, "uniform", "m"),
    Group("servo_angle", "pi", (12, 13), 0.012, 5.67e-3, "uniform", "rad"),
    Group("servo_rate", "pi", (14, 15), 0.012, 0.50772, "uniform", "rad/s"),
)

# The UAV alone (Table A.1, no camera): y of (A.3) = [q; eta_dot; alpha_R_dot; alpha_L_dot]. Servo noise uniform,
# the rest Gaussian with bound = 3 sigma.
UAV_PI_NAMES = ("x", "y", "z", "phi", "theta", "psi", "alpha_R", "alpha_L", "phi_dot", "theta_dot", "psi_dot",
                "alpha_R_dot", "alpha_L_dot")
UAV_GROUPS = (
    Group("gps", "pi", (0, 1), 0.120, 0.15, "gaussian", "m"),
    Group("baro", "pi", (2,), 0.012, 0.51, "gaussian", "m"),
    Group("imu_att", "pi", (3, 4, 5), 0.012, 5.15e-3, "gaussian", "rad"),
    Group("servo_angle", "pi", (6, 7), 0.012, 5.67e-3, "uniform", "rad"),
    Group("imu_rate", "pi", (8, 9, 10), 0.012, 5.15e-3, "gaussian", "rad/s"),
    Group("servo_rate", "pi", (11, 12), 0.012, 0.50772, "uniform", "rad/s"),
)


@dataclass(frozen=True)
class Suite:
    """A vehicle's sensor FMU: its groups and the names of its measurement model's outputs."""

    vehicle: str
    model_identifier: str
    groups: tuple[Group, ...]
    pi_names: tuple[str, ...]
    description: str


LOAD_SUITE = Suite("load", "TiltloadSensors", GROUPS, ZSE_NAMES,
                   "Sensor suite of Rego (UFMG 2016): exact state, q with Gaussian noise (Sec. 5.3), GPS, barometer, "
                   "IMU, camera and servo encoders with their periods and noise (Table 5.8)")
UAV_SUITE = Suite("uav", "TiltrotorSensors", UAV_GROUPS, UAV_PI_NAMES,
                  "Sensor suite of the tilt-rotor UAV alone (Rego, UFMG 2016, Table A.1): exact state, GPS, barometer, "
                  "IMU and servo encoders with their periods and noise")
SUITES = {"load": LOAD_SUITE, "uav": UAV_SUITE}
