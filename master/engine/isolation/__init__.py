"""FMUs in worker processes of their own: the master's side (process), the worker (worker), the messages (wire)."""
