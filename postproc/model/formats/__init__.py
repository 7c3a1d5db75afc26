"""Readers for measurement data in formats other than the shared schema."""
