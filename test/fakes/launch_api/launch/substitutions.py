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


class EnvironmentVariable:
    """The value of a variable of the launch context's environment; ``default_value`` when it is not set."""

    def __init__(self, name, *, default_value=None):
        self.name, self.default_value = name, default_value

    def perform(self, context):
        value = context.environment.get(self.name, self.default_value)
        if value is None:
            raise SubstitutionFailure(f"environment variable '{self.name}' does not exist")
        return value
