"""Robots: the interface, the loader and the built-in robots."""
