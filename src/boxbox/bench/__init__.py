"""Benchmarks: boxbox beside TORCS's own robots in the same run (bench, speed, pits, telemetry, sweep, soak)."""
