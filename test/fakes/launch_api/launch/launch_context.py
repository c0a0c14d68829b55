"""Stand-in for ``launch.launch_context``: the launch configurations (argument values) as text."""


class LaunchContext:
    """What actions and substitutions see while a description is visited."""

    def __init__(self):
        self.__launch_configurations = {}

    @property
    def launch_configurations(self):
        """The launch configurations (name -> text), as launch's property of that name."""
        return self.__launch_configurations
