"""Flattens a composed USD stage into the Cirrus scene format (exporter/FORMAT.md)."""
