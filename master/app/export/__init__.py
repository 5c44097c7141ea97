"""The loop handed to other tools: every FMU, the packages and the port contract in one archive (`bundle`, `tiltload
bundle`) and the loop as an SSP package (`ssp`, `tiltload ssp export`). docs/ports.md."""
