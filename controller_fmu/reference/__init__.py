"""Reference implementations in numpy: the oracle the controller FMU's C is tested against, and design-time tools."""
