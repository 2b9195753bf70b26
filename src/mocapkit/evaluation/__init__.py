"""Sweeps, benchmarks and the demo: the paper's experiments and our own measurements."""
