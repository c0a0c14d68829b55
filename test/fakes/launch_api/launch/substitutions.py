"""Stand-in for ``launch.substitutions``."""


class LaunchConfiguration:
    """The value of a launch argument, as text."""

    def __init__(self, variable_name, *, default=None):
        self.variable_name = variable_name
        self.default = default

    def perform(self, context):
        if self.variable_name in context:
            return context[self.variable_name]
        if self.default is None:
            raise KeyError(f"launch configuration '{self.variable_name}' does not exist")
        return self.default
