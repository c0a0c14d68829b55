"""Evaluate a launch file with the stand-in launch API: ``evaluate_launch.py FILE name:=value ...`` -> JSON."""

import importlib.util
import json
import sys

from launch.actions import DeclareLaunchArgument


def main(argv):
    spec = importlib.util.spec_from_file_location("launch_file", argv[0])
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    given = dict(arg.split(":=", 1) for arg in argv[1:])
    context, nodes = {}, []
    for entity in description.entities:
        if isinstance(entity, DeclareLaunchArgument):
            value = given.pop(entity.name, entity.default_value)
            entity.check(value)
            context[entity.name] = value
        else:
            evaluated = entity.evaluate(context)
            if evaluated is not None:
                nodes.append(evaluated)
    if given:
        raise SystemExit(f"unknown launch arguments {sorted(given)}")
    print(json.dumps({"arguments": context, "nodes": nodes}))


if __name__ == "__main__":
    main(sys.argv[1:])
