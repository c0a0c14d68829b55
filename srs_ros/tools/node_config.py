"""``python -m srs_ros.tools.node_config``: write config/<node>.yaml from the nodes' parameter specs.

The parameter files of ``hardware_node``, ``gait_player``, ``trajectory_server``, ``camera_tracker`` and
``navigator`` in ``config/`` list every parameter of the node with its default, range and description.
They are generated from the node's parameter specs (:class:`~srs_ros.ros.parameters.ParameterSpec`, the
one place a default is written), and ``test/tools/test_node_config.py`` keeps them equal, so they cannot
drift from the nodes. Generated rather than cut down to a lab's overrides because the launch file passes
them and a newcomer reads them: each lists what its node takes, which ``ros2 param describe`` shows only
with the node running. A lab's own values go in a params file of its own, passed after these.

Examples: ``python -m srs_ros.tools.node_config`` (rewrite the files after changing a spec),
``python -m srs_ros.tools.node_config --check`` (compare only: exit 1 naming each file that differs).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

import yaml

from srs_ros.core.files import write_atomically
from srs_ros.core.robot import config_dir
from srs_ros.ros.parameters import ParameterSpec, params_file_key

#: What each generated file says above its parameters (how the node reads them), by node.
HEADERS = {
    "hardware_node": (
        "Pass with  hardware_node --ros-args --params-file config/hardware_node.yaml",
        "All but max_pressure_bar and realtime_priority (read-only, start-up) and lag_compensation (live) take",
        "effect at the next lifecycle configure.",
    ),
    "gait_player": (
        "Pass with  ros2 run srs_ros gait_player --ros-args --params-file config/gait_player.yaml",
        "Live: rate_hz, amplitude_scale, frequency_hz, reverse, ramp_time_s, blend_time_s. `cycles` is read at",
        "~/start.",
    ),
    "trajectory_server": (
        "Pass with  ros2 run srs_ros trajectory_server --ros-args --params-file config/trajectory_server.yaml",
        "Each gait's own parameters default to config/gaits.yaml (the one place they live); override one in a",
        "params file as a nested block, e.g.  `serpentine: {body_wavelengths: 1.5}`  (the parameter",
        "serpentine.body_wavelengths). Parameters take effect at the next ~/regenerate call.",
    ),
    "camera_tracker": (
        "Pass with  ros2 run srs_ros camera_tracker --ros-args --params-file config/camera_tracker.yaml",
        "All read-only (restart the node to change one).",
    ),
    "navigator": (
        "Pass with  ros2 run srs_ros navigator --ros-args --params-file config/navigator.yaml",
        "The navigation settings come from srs_ros/core/navigation/settings.py (NAVIGATION_TABLE); all live but",
        "those marked read-only. loop_path is read when a goal_path arrives. States and topics: docs/navigation.md.",
    ),
}
NODES = tuple(HEADERS)


def node_specs(node: str) -> tuple[ParameterSpec, ...]:
    """The parameter specs a node declares (the trajectory server's without the gaits' own, kept in gaits.yaml)."""
    if node == "hardware_node":
        from srs_ros.nodes.hardware_node import PARAMETERS
    elif node == "gait_player":
        from srs_ros.nodes.gait_player import PARAMETERS
    elif node == "camera_tracker":
        from srs_ros.nodes.camera_tracker import PARAMETERS
    elif node == "navigator":
        from srs_ros.nodes.navigator import PARAMETERS
    elif node == "trajectory_server":
        from srs_ros.core.gait.library import list_gaits
        from srs_ros.core.robot import default_robot
        from srs_ros.nodes.trajectory_server import ROBOT_FILE, base_parameters

        PARAMETERS = (*base_parameters(default_robot(), sorted(list_gaits())), ROBOT_FILE)  # noqa: N806
    else:
        raise ValueError(f"node {node!r}: expected one of {list(NODES)}")
    return tuple(PARAMETERS)


def robot_dependent(node: str) -> frozenset[str]:
    """The parameters whose default comes from the robot file (the trajectory server's ``amplitude_bar``).

    Written as a comment: a value in the file refused a robot with a lower limit (a helper's review).
    """
    if node != "trajectory_server":
        return frozenset()
    from srs_ros.core.gait.library import list_gaits
    from srs_ros.core.robot import default_robot
    from srs_ros.nodes.trajectory_server import base_parameters

    robot = default_robot()
    lower = dataclasses.replace(robot, max_pressure_bar=robot.max_pressure_bar / 2)
    gaits = sorted(list_gaits())
    return frozenset(a.name for a, b in zip(base_parameters(robot, gaits), base_parameters(lower, gaits)) if a != b)


def yaml_value(value) -> str:
    """``value`` as one YAML flow scalar or list (a double keeps its point: ``4.0``, so ROS types it double)."""
    return yaml.safe_dump(value, default_flow_style=True, width=10_000).splitlines()[0]


def comment(spec: ParameterSpec) -> str:
    """What a parameter is, with its range or choices where it has them, and whether it is read-only."""
    text = spec.description
    if spec.minimum is not None or spec.maximum is not None or spec.choices:
        text += f"; {dataclasses.replace(spec.field, example='').expected}"
    return text + ("; read-only" if spec.read_only and "read-only" not in text else "")


def config_text(node: str) -> str:
    """The whole params file of ``node``: header, then one line per parameter, default and comment."""
    specs = node_specs(node)
    lines = [f"# Parameters of {node} (srs_ros/nodes/{node}.py), GENERATED from its parameter specs by",
             "#   python -m srs_ros.tools.node_config",
             "# and tested equal to them: change a default or a range in the spec, then run the generator; do not",
             "# edit this file. A lab's own values go in a params file of its own, passed after this one.",
             *(f"# {line}" for line in HEADERS[node]),
             f"{params_file_key(node)}:", "  ros__parameters:"]
    from_robot = robot_dependent(node)
    entries = [f"{'# ' if spec.name in from_robot else ''}{spec.name}: {yaml_value(spec.default)}" for spec in specs]
    width = max(len(entry) for entry in entries) + 2
    lines += [f"    {entry.ljust(width)}# {comment(spec)}"
              + ("; default: the robot file's limit (config/robot.yaml's here), so not set" if spec.name in from_robot
                 else "") for entry, spec in zip(entries, specs)]
    return "\n".join(lines) + "\n"


def config_path(node: str, folder: Path | None = None) -> Path:
    """Where the params file of ``node`` lives (the package's ``config/``)."""
    return (folder or config_dir()) / f"{node}.yaml"


def main(argv: list[str] | None = None) -> int:
    """Write the files (default) or, with ``--check``, list those that differ from the specs (exit 1)."""
    parser = argparse.ArgumentParser(prog="python -m srs_ros.tools.node_config", description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="compare only; exit 1 if a file differs")
    parser.add_argument("--config-dir", type=Path, default=None, help="folder of the files (default: the package's)")
    args = parser.parse_args(argv)
    if args.config_dir is not None and not args.config_dir.is_dir():  # a traceback, or "every file differs"
        parser.error(f"--config-dir {args.config_dir}: not a folder; expected the folder of the nodes' params files")
    stale = []
    for node in NODES:
        path, text = config_path(node, args.config_dir), config_text(node)
        if path.is_file() and path.read_text(encoding="utf-8") == text:
            continue
        stale.append(path)
        if not args.check:
            try:
                write_atomically(path, text)
            except OSError as exc:
                print(f"node_config: cannot write {path} ({exc.strerror or exc}); choose a writable folder",
                      file=sys.stderr)
                return 2
            print(f"wrote {path}")
    if args.check and stale:
        print("differ from the nodes' parameter specs (run python -m srs_ros.tools.node_config): "
              + ", ".join(str(p) for p in stale), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
