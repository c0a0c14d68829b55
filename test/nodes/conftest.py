"""Fixtures of the node tests: the shared hardware node process of a module (srs_testing.hardware_rig)."""

from srs_testing.hardware_rig import hardware, shared_nodes  # noqa: F401 (pytest fixtures, used by name)
