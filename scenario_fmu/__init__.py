"""Scenario FMU: the thesis reference trajectories (Sec. 5.1.2) and the wind-gust disturbances on the load (Sec. 5.1.3)."""
