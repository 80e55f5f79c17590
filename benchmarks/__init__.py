"""Benchmarks: each prints our figure beside its anchor's, measured in the same run."""
