"""The public Python API, re-exported by the `tiltload` package (tiltload/__init__.py): docs/api.md."""
