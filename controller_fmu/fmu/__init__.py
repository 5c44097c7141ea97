"""The controller+estimator FMU: its variable table, its C (c/) and its build recipe."""
