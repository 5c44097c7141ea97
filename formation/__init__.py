"""The formation of three tilt-rotor UAVs (thesis Appendix B)."""
