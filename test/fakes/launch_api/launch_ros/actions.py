"""Stand-in for ``launch_ros.actions``: Node and LifecycleNode with Jazzy's keyword arguments."""

from launch_ros.parameter_descriptions import ParameterValue, coerce


class Node:
    """A ROS node process."""

    kind = "Node"

    def __init__(self, *, executable, package=None, name=None, namespace=None, exec_name=None, parameters=None,
                 remappings=None, ros_arguments=None, arguments=None, output="log", condition=None, **kwargs):
        self.executable, self.package, self.name, self.namespace = executable, package, name, namespace
        self.parameters = list(parameters or [])
        self.condition = condition

    def evaluate(self, context):
        """What launch_ros hands the process: name, namespace, parameter files and values."""
        if self.condition is not None and not self.condition.evaluate(context):
            return None
        namespace = self.namespace.perform(context) if hasattr(self.namespace, "perform") else self.namespace
        files, values = [], {}
        for entry in self.parameters:
            if isinstance(entry, str):
                files.append(entry)
                continue
            for key, value in entry.items():
                if isinstance(value, ParameterValue):
                    values[key] = value.evaluate(context)
                elif hasattr(value, "perform"):  # a bare substitution: read as YAML, as launch_ros does
                    values[key] = coerce(value.perform(context), None)
                else:
                    values[key] = value
        return {"kind": self.kind, "package": self.package, "executable": self.executable, "name": self.name,
                "namespace": namespace, "parameter_files": files, "parameters": values}


class LifecycleNode(Node):
    """A managed (lifecycle) node; name and namespace are required, as in Jazzy."""

    kind = "LifecycleNode"

    def __init__(self, *, name, namespace, **kwargs):
        super().__init__(name=name, namespace=namespace, **kwargs)
