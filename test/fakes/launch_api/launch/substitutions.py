"""Stand-in for ``launch.substitutions``."""


class SubstitutionFailure(RuntimeError):
    """Raised when a Substitution fails."""


class LaunchConfiguration:
    """The value of a launch argument, as text."""

    def __init__(self, variable_name, *, default=None):
        self.variable_name = variable_name
        self.default = default

    def perform(self, context):
        if self.variable_name not in context.launch_configurations:
            if self.default is None:
                raise SubstitutionFailure(f"launch configuration '{self.variable_name}' does not exist")
            return self.default
        return context.launch_configurations[self.variable_name]
