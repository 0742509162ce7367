"""Newton adapter (being written)."""
