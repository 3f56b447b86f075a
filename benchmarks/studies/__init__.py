"""Measurement studies: scripts that answer one question each through the project's runner (index: README.md)."""
