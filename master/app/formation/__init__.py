"""The thesis's third system, the formation of three UAVs (Appendix B): its seven-FMU system (`system`) and its runs
(`runner`, `tiltload formation`). docs/formation.md."""
