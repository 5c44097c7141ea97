"""SSP packages: `export` (SSP 1.0; SSP 2.0 in ../ssp2.py), `load` (both), `schema` (the shared names and the schema
check); the archive unpacker they use is ../zip_unpack.py."""
