"""SSP packages, 1.0 and 2.0: `export` (SSP 1.0), `ssp2` (SSP 2.0, for FMI 3.0), `load` (both), `schema` (the shared
names and the schema check), and the archive unpacker `load` uses, `zip_unpack` (an untrusted archive unpacked within
limits). The tiltload loop as a package: master/app/export/ssp.py."""
