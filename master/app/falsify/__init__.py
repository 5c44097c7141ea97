"""Falsification: search the inputs for a case that violates a requirement (docs/falsification.md)."""
