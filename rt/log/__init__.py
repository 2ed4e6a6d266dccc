"""Logs and measurements: MCAP and rrd files, the writer thread, the measurement format, FRF files, the design record."""
