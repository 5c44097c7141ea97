"""Faults between outputs and inputs (docs/faults.md): `schedule` (the vocabulary, Fault), `parse` (JSON, fault files,
libcosim scenarios), `apply` (the Manipulator inside an execution), `draw` (the noise and jitter draws)."""
