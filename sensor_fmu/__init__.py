"""Sensor-suite FMU: the measurement model of the thesis (4.12, 4.22) sampled on each sensor's period."""
