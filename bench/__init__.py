"""Benchmarks of aiogenomix, measured side by side with the loopback floor (run: ``./run bench``)."""
