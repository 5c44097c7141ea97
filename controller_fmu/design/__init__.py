"""The controllers of ch. 3, designed: synthesize.design(kind) is the entry point (cached; artifacts saved as JSON)."""
