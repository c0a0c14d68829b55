"""Evaluate a launch file with the stand-in launch API: ``evaluate_launch.py FILE name:=value ...`` -> JSON.

Like ``ros2 launch``: the arguments given are launch configurations before the description is visited;
the entities are visited in order (what an OpaqueFunction returns right after it); an exception stops the
launch with launch's one error line and exit status 1, before any later node is started.
"""

import importlib.util
import json
import sys

from launch import LaunchContext
from launch.actions import DeclareLaunchArgument
from launch_ros.actions import Node


def visit(entities, context, nodes):
    for entity in entities:
        if isinstance(entity, Node):
            evaluated = entity.evaluate(context)
            if evaluated is not None:
                nodes.append(evaluated)
        else:
            visit(entity.visit(context) or [], context, nodes)


def main(argv):
    spec = importlib.util.spec_from_file_location("launch_file", argv[0])
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    context, nodes = LaunchContext(), []
    context.launch_configurations.update(arg.split(":=", 1) for arg in argv[1:])
    declared = {entity.name for entity in description.entities if isinstance(entity, DeclareLaunchArgument)}
    unknown = sorted(set(context.launch_configurations) - declared)
    if unknown:
        raise SystemExit(f"unknown launch arguments {unknown}")
    try:
        visit(description.entities, context, nodes)
    except Exception as exc:  # launch.LaunchService: log the one line, shut down, exit status 1
        print(f"[ERROR] [launch]: Caught exception in launch (see debug for traceback): {exc}", file=sys.stderr)
        raise SystemExit(1) from None
    print(json.dumps({"arguments": dict(context.launch_configurations), "nodes": nodes}))


if __name__ == "__main__":
    main(sys.argv[1:])
