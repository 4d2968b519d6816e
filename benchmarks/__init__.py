"""vibdyn's regression benchmarks (not part of the installed package): ``python -m benchmarks --help``."""
