"""boxbox: Python robots for TORCS."""
