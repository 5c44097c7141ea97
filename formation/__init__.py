"""The formation of three tilt-rotor UAVs (thesis Appendix B): dual-quaternion kinematics, the formation laws, the
D-stable H-infinity tracker design, and their two FMUs (build). The seven-FMU system and its run are in master/app."""
