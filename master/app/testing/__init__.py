"""The pytest plugin for a user's controller repository (registered as `pytest11`: tiltload) and its assertion
helpers (public as tiltload.testing): docs/api.md."""
