"""Stand-in for ``launch.conditions``."""


class IfCondition:
    """True when the expression performs to 'true' or '1' (any case), false for 'false' or '0'."""

    def __init__(self, predicate_expression):
        self.predicate_expression = predicate_expression

    def evaluate(self, context):
        text = self.predicate_expression.perform(context).strip().lower()
        if text not in ("true", "1", "false", "0"):
            raise ValueError(f"Unknown condition value '{text}'")
        return text in ("true", "1")
