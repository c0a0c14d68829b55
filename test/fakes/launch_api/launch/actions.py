"""Stand-in for ``launch.actions``."""


class DeclareLaunchArgument:
    """A launch argument with a default and, optionally, the only values it accepts."""

    def __init__(self, name, *, default_value=None, description="", choices=None, **kwargs):
        self.name = name
        self.default_value = default_value
        self.description = description
        self.choices = choices

    def check(self, value):
        if self.choices is not None and value not in self.choices:
            raise ValueError(f"Argument '{self.name}' provided value '{value}' is not valid. "
                             f"Valid options are: {self.choices}")
