"""Names, units and meanings of the plant's states, inputs and outputs (stable names that other tools and the tests rely on: docs/ports.md).

CasADi-free: the FMU, the master and the docs read it.
"""

from __future__ import annotations

COORDINATES = ("x", "y", "z", "phi", "theta", "psi", "gamma_1", "gamma_2", "alpha_R", "alpha_L")
_COORD_INFO = {
    "x": ("m", "load position x in I"),
    "y": ("m", "load position y in I"),
    "z": ("m", "load position z in I"),
    "phi": ("rad", "load roll (Z-Y-X Euler)"),
    "theta": ("rad", "load pitch (Z-Y-X Euler)"),
    "psi": ("rad", "load yaw (Z-Y-X Euler)"),
    "gamma_1": ("rad", "UAV tilt relative to the rod, R_B^L = Rx(-gamma_1) Ry(-gamma_2)"),
    "gamma_2": ("rad", "UAV tilt relative to the rod, second angle"),
    "alpha_R": ("rad", "right thruster tilt angle"),
    "alpha_L": ("rad", "left thruster tilt angle"),
}

def _states(coordinates, info) -> tuple[tuple[str, str, str], ...]:
    return tuple((n, *info[n]) for n in coordinates) + tuple((f"{n}_dot", f"{info[n][0]}/s", f"rate of {n}") for n in coordinates)


STATES = _states(COORDINATES, _COORD_INFO)
STATE_NAMES = tuple(s[0] for s in STATES)

# The UAV alone (Appendix A): the same names, of the UAV's geometric centre and attitude.
UAV_COORDINATES = ("x", "y", "z", "phi", "theta", "psi", "alpha_R", "alpha_L")
_UAV_COORD_INFO = {
    **_COORD_INFO,
    "x": ("m", "UAV geometric centre x in I"),
    "y": ("m", "UAV geometric centre y in I"),
    "z": ("m", "UAV geometric centre z in I"),
    "phi": ("rad", "UAV roll (Z-Y-X Euler)"),
    "theta": ("rad", "UAV pitch (Z-Y-X Euler)"),
    "psi": ("rad", "UAV yaw (Z-Y-X Euler)"),
}
UAV_STATES = _states(UAV_COORDINATES, _UAV_COORD_INFO)
UAV_STATE_NAMES = tuple(s[0] for s in UAV_STATES)

INPUTS = (
    ("f_R", "N", "right propeller thrust (saturated to [f_min, f_max])"),
    ("f_L", "N", "left propeller thrust (saturated to [f_min, f_max])"),
    ("tau_R", "N.m", "right servo torque (saturated to +-tau_max)"),
    ("tau_L", "N.m", "left servo torque (saturated to +-tau_max)"),
)
DISTURBANCES = (
    ("d_x", "N", "disturbance force on the load's centre, x in I"),
    ("d_y", "N", "disturbance force on the load's centre, y in I"),
    ("d_z", "N", "disturbance force on the load's centre, z in I"),
)
INPUT_NAMES = tuple(i[0] for i in INPUTS)
DISTURBANCE_NAMES = tuple(i[0] for i in DISTURBANCES)
UAV_DISTURBANCES = tuple((n, u, d.replace("the load's centre", "the UAV's geometric centre")) for n, u, d in DISTURBANCES)

# Order = the compiled library's output vector (model.PlantModel.diagnostics).
DIAGNOSTICS = (
    ("x_B", "m", "UAV geometric centre x in I (thesis 4.16)"),
    ("y_B", "m", "UAV geometric centre y in I"),
    ("z_B", "m", "UAV geometric centre z in I"),
    ("phi_B", "rad", "UAV roll (thesis 4.17)"),
    ("theta_B", "rad", "UAV pitch (thesis 4.18)"),
    ("psi_B", "rad", "UAV yaw (thesis 4.19)"),
    ("E_kin", "J", "total kinetic energy"),
    ("E_pot", "J", "total potential energy (zero at z = 0)"),
    ("E_total", "J", "E_kin + E_pot"),
    ("p_x", "kg.m/s", "total linear momentum x"),
    ("p_y", "kg.m/s", "total linear momentum y"),
    ("p_z", "kg.m/s", "total linear momentum z"),
    ("L_x", "kg.m2/s", "total angular momentum about the inertial origin, x"),
    ("L_y", "kg.m2/s", "total angular momentum about the inertial origin, y"),
    ("L_z", "kg.m2/s", "total angular momentum about the inertial origin, z"),
)
DIAGNOSTIC_NAMES = tuple(d[0] for d in DIAGNOSTICS)
APPLIED = tuple((f"{n}_applied", unit, f"{n} after saturation, as applied to the plant") for n, unit, _ in INPUTS)
