"""Stand-in for ``launch_ros.parameter_descriptions``."""

import yaml


def coerce(text, value_type):
    """``launch.utilities.type_utils.coerce_to_type`` for scalars."""
    if value_type is None:
        return yaml.safe_load(text)
    if value_type is str:
        return text
    if value_type in (int, float):
        return value_type(text)
    value = yaml.safe_load(text)
    if not isinstance(value, value_type):
        raise ValueError(f"Cannot convert value '{text}' to '{value_type}'")
    return value


class ParameterValue:
    """A parameter value whose substitution result is converted to ``value_type``."""

    def __init__(self, value, *, value_type=None):
        self.value = value
        self.value_type = value_type

    def evaluate(self, context):
        text = self.value.perform(context) if hasattr(self.value, "perform") else self.value
        return coerce(text, self.value_type) if isinstance(text, str) else text
