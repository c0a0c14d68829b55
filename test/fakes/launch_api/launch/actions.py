"""Stand-in for ``launch.actions``."""

import collections.abc


class DeclareLaunchArgument:
    """A launch argument with a default and, optionally, the only values it accepts."""

    def __init__(self, name, *, default_value=None, description="", choices=None, **kwargs):
        self.name = name
        self.default_value = default_value
        self.description = description
        self.choices = choices

    def visit(self, context):
        """launch's ``execute``: a value given on the command line wins over the default; choices are enforced."""
        if self.name not in context.launch_configurations:
            if self.default_value is None:
                raise RuntimeError(f'Required launch argument "{self.name}" was not provided.')
            context.launch_configurations[self.name] = self.default_value
        value = context.launch_configurations[self.name]
        if self.choices is not None and value not in self.choices:
            raise RuntimeError(f'Argument "{self.name}" provided value "{value}" is not valid. Valid options '
                               f"are: {self.choices}")


class OpaqueFunction:
    """An action that calls ``function(context, *args, **kwargs)``; what it returns is visited next."""

    def __init__(self, *, function, args=None, kwargs=None, condition=None):
        if not callable(function):
            raise TypeError(f"OpaqueFunction expected a callable for 'function', got '{type(function)}'")
        if not isinstance(args, (collections.abc.Iterable, type(None))):
            raise TypeError("OpaqueFunction: 'args' must be an iterable or None")
        if not isinstance(kwargs, (dict, type(None))):
            raise TypeError("OpaqueFunction: 'kwargs' must be a dict or None")
        self.function, self.args, self.kwargs, self.condition = function, args or [], kwargs or {}, condition

    def visit(self, context):
        """launch's ``Action.visit``: execute unless a condition says no."""
        if self.condition is None or self.condition.evaluate(context):
            return self.function(context, *self.args, **self.kwargs)
        return None
