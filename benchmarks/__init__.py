"""Benchmarks of frcontrol (run as modules from the repository root)."""
