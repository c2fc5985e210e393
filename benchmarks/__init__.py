"""The timings: each a module run from the repository root as `python -m benchmarks.NAME` (its docstring says what it
times and its targets); `make bench` runs every bench_*.py. What they share is in `benchmarks.common`."""
