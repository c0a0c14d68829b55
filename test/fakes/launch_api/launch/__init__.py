"""Stand-in for ROS 2 ``launch`` (see ../README.md): just what srs.launch.py uses."""

from launch.launch_context import LaunchContext


class LaunchDescription:
    """The entities of a launch file, in order."""

    def __init__(self, initial_entities=None):
        self.entities = list(initial_entities or [])


__all__ = ["LaunchContext", "LaunchDescription"]
