"""Flattens a composed USD stage into the Cirrus scene format (scenes/FORMAT.md)."""
