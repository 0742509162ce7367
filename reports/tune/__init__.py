"""A search over an engine's settings against the exact solution (``hoopbench tune``)."""
