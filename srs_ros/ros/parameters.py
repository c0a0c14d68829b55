"""ROS parameters of the srs_ros nodes: declared once per node from specs, typed as ros2cli types them, guarded."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from srs_ros.core.errors import ConfigurationError
from srs_ros.core.schema import Field


@dataclass(frozen=True)
class ParameterSpec:
    """One declared parameter: default value, allowed range (inclusive) and description with unit.

    Its type and range are a field of the one schema (:attr:`field`, :mod:`srs_ros.core.schema`): the
    check of every set and start-up value, and its refusal text, come from there.
    """

    name: str
    default: Any
    description: str
    minimum: float | int | None = None
    maximum: float | int | None = None
    read_only: bool = False
    additional_constraints: str = ""
    #: The values a string parameter may take (empty: any string).
    choices: tuple[str, ...] = ()
    #: True where the minimum itself is refused (``> 0``); the descriptor's range still includes it.
    above_minimum: bool = False
    #: Unit of the value ('' where the description names it).
    unit: str = ""
    #: The exact number of items of a list parameter (None: any).
    length: int | None = None

    @classmethod
    def from_field(cls, field: Field, read_only: bool = False, name: str | None = None) -> ParameterSpec:
        """The parameter of a schema field (``name`` replaces the field's, e.g. ``serpentine.radius_m``)."""
        return cls(name or field.name, field.default, field.description, field.minimum, field.maximum, read_only,
                   additional_constraints=field.expected, choices=tuple(field.choices),
                   above_minimum=field.above_minimum, unit=field.unit, length=field.length)

    @property
    def is_double(self) -> bool:
        """True for a double parameter (a float default); it also accepts integers (:func:`declare_parameters`)."""
        return isinstance(self.default, float)

    @property
    def field(self) -> Field:
        """The parameter as a field of the schema: its type from the default, its range, unit and choices."""
        kind = type(self.default) if isinstance(self.default, (bool, int, float, str)) else list
        item = _item_type(self.default) if kind is list else None
        return Field(self.name, kind, self.default, self.minimum, self.maximum, self.unit, self.description,
                     choices=self.choices, above_minimum=self.above_minimum, item=item, length=self.length,
                     example=repr(self.default) if self.is_double else "")

    def descriptor(self) -> ParameterDescriptor:
        """A ParameterDescriptor that rclpy enforces on every set (range, read-only)."""
        desc = ParameterDescriptor(name=self.name, description=self.description, read_only=self.read_only,
                                   additional_constraints=self.additional_constraints)
        if self.minimum is not None and self.maximum is not None and not isinstance(self.default, bool):
            if isinstance(self.default, int):
                desc.integer_range = [IntegerRange(from_value=int(self.minimum), to_value=int(self.maximum), step=1)]
            elif isinstance(self.default, float):
                desc.floating_point_range = [FloatingPointRange(from_value=float(self.minimum),
                                                                to_value=float(self.maximum), step=0.0)]
        return desc

    def check(self, value: Any) -> str:
        """'' if ``value`` is acceptable, else why not: ``<name> is <value>; expected <what>; <description>.``."""
        reason = self.field.reason(value)
        return f"{reason}; {self.description}." if reason else ""


def _item_type(default: Any) -> type | None:
    """The item type of a list parameter, from its default (None: any)."""
    items = list(default or ())
    for kind in (bool, int, float, str):
        if items and all(type(v) is kind or (kind is float and type(v) is int) for v in items):
            return kind
    return None


def declare_parameters(node: Node, specs: Iterable[ParameterSpec]) -> dict[str, ParameterSpec]:
    """Declare every spec on ``node`` with its descriptor; return them by name. Once per node: all of them.

    Values are typed as ros2cli and rcl type them: ``3`` is an INTEGER, ``0`` too. So a double parameter also
    takes an integer, converted to a double, and a string parameter an integer as its text (``-p source:=0``,
    a camera index): at start-up (``-p rate_hz:=500``, a launch argument ``amplitude_bar:=3``) and at run time
    (``ros2 param set /gait_player rate_hz 500``). rclpy types parameters strictly and would refuse them.
    Every start-up value is then checked as a set would be (choices, ``> 0``, list lengths: rclpy's
    descriptor checks only type and range): a bad one raises ConfigurationError, the node does not start.

    The run-time conversion is a pre-set callback, and rclpy (7.1, Jazzy) concatenates the lists
    several such callbacks return: a second call would hand every parameter over twice, once still an
    integer, and the set would be refused. So a second call on the same node raises RuntimeError.
    """
    if getattr(node, "_srs_declared_parameters", None) is not None:
        raise RuntimeError(f"declare_parameters called twice on node {node.get_name()!r} (it declared "
                           f"{sorted(node._srs_declared_parameters)} already); expected one call with every "
                           "parameter of the node, since rclpy concatenates the outputs of several pre-set "
                           "callbacks and integers for doubles would then be refused.")
    by_name = {spec.name: spec for spec in specs}
    node._srs_declared_parameters = by_name
    convert = partial(integers_as_declared, _types_taking_integers(by_name))
    # Start-up overrides are read by declare_parameter before any callback runs, so convert them here
    # (rclpy keeps them in Node._parameter_overrides and offers no public setter).
    overrides = getattr(node, "_parameter_overrides", {})
    for name in set(by_name) & set(overrides):
        overrides[name] = convert([overrides[name]])[0]
    for spec in by_name.values():
        node.declare_parameter(spec.name, spec.default, spec.descriptor())
    for spec in by_name.values():
        reason = spec.check(node.get_parameter(spec.name).value)
        if reason:
            raise ConfigurationError(f"invalid start-up parameter: {reason}")
    node.add_pre_set_parameters_callback(convert)
    return by_name


def _types_taking_integers(specs: dict[str, ParameterSpec]) -> dict[str, Parameter.Type]:
    """The parameters that take an INTEGER as another type: doubles (its value) and strings (its text)."""
    kinds = {}
    for name, spec in specs.items():
        if spec.is_double:
            kinds[name] = Parameter.Type.DOUBLE
        elif isinstance(spec.default, str):
            kinds[name] = Parameter.Type.STRING
    return kinds


def startup_value(node: Node, spec: ParameterSpec) -> Any:
    """The value ``spec`` will be declared with: its start-up override (``-p``, a params file) or its default.

    For a node whose other parameters depend on one of them (e.g. a range from the robot file), read
    before the one :func:`declare_parameters` call. Raises ConfigurationError for a value of the wrong type.
    """
    override = getattr(node, "_parameter_overrides", {}).get(spec.name)
    if override is not None:  # typed as declare_parameters will: 3 for a double is 3.0, for a string "3"
        override = integers_as_declared(_types_taking_integers({spec.name: spec}), [override])[0]
    value = spec.default if override is None else override.value
    reason = spec.check(value)
    if reason:
        raise ConfigurationError(f"invalid start-up parameter: {reason}")
    return float(value) if spec.is_double else value


def integers_as_declared(kinds: dict[str, Parameter.Type], params: list[Parameter]) -> list[Parameter]:
    """``params`` with each integer value of a parameter in ``kinds`` as that type: a double or its decimal text."""

    def converted(p: Parameter) -> Parameter:
        kind = kinds.get(p.name)
        if kind is None or p.type_ != Parameter.Type.INTEGER:
            return p
        return Parameter(p.name, kind, float(p.value) if kind == Parameter.Type.DOUBLE else str(p.value))

    return [converted(p) for p in params]


def params_file_key(node: str) -> str:
    """The key of ``node``'s block in a params file: ``/**/node``, so it applies in any namespace.

    A bare ``node:`` key means ``/node`` only; under ``ros2 launch ... namespace:=snake1`` (or ``-r __ns:=/snake1``)
    such a block is silently not applied.
    """
    return f"/**/{node}"


def check_parameters(specs: dict[str, ParameterSpec], params: Sequence,
                     extra_check: Callable[[str, Any], str] | None = None) -> SetParametersResult:
    """A set-parameters callback body: reject the whole set with a reason if any value is bad."""
    for param in params:
        spec = specs.get(param.name)
        reason = spec.check(param.value) if spec else ""
        if not reason and extra_check is not None:
            reason = extra_check(param.name, param.value)
        if reason:
            return SetParametersResult(successful=False, reason=reason)
    return SetParametersResult(successful=True)


def guard_parameter_services(node: Node) -> None:
    """Make malformed ``set_parameters`` requests refusals instead of the end of the node or a new parameter.

    rclpy's own parameter services raise on a value of an unknown type (e.g. type 99 sent by a broken
    or hostile client), and the exception stops the node's executor: for the hardware node, a vent and
    an exit. They also create a parameter named '' although the nodes declare every parameter they
    take. The guarded services answer such a parameter with ``successful=False`` and the reason, and
    handle every other parameter of the request as before.
    """
    from rcl_interfaces.srv import SetParameters

    def refusal(parameter) -> SetParametersResult | None:
        if not node.has_parameter(parameter.name):
            return SetParametersResult(successful=False, reason=f"{node.get_name()} has no parameter "
                                       f"{parameter.name!r}; `ros2 param list` shows them.")
        try:
            Parameter.from_parameter_msg(parameter)
        except (ValueError, TypeError) as exc:
            return SetParametersResult(successful=False, reason=f"{parameter.name}: malformed value refused "
                                       f"({type(exc).__name__}: {exc}); expected a value of a ROS parameter type.")
        return None

    def one_at_a_time(callback):
        def guarded(request, response):
            response.results = []
            for parameter in request.parameters:
                refused = refusal(parameter)
                response.results.append(refused or callback(SetParameters.Request(parameters=[parameter]),
                                                            SetParameters.Response()).results[0])
            return response
        return guarded

    def all_or_nothing(callback):
        def guarded(request, response):
            refused = next(filter(None, map(refusal, request.parameters)), None)
            if refused is not None:
                response.result = refused
                return response
            return callback(request, response)
        return guarded

    for service in node.services:
        if service.srv_name.endswith("/set_parameters"):
            service.callback = one_at_a_time(service.callback)
        elif service.srv_name.endswith("/set_parameters_atomically"):
            service.callback = all_or_nothing(service.callback)


#: The parameter that puts a real-time node (gait_player, hardware_node) on the SCHED_FIFO scheduler.
REALTIME_PRIORITY = ParameterSpec(
    "realtime_priority", 0, "SCHED_FIFO priority 1-98 for every thread of this process, so CPU load cannot delay "
    "setpoints; 0 = the normal scheduler; needs an rtprio limit or CAP_SYS_NICE (README)", 0, 98, read_only=True)

#: The simulated robot whose camera and bands the ``sim_bands`` preset follows (camera_tracker, navigator):
#: srs_bringup --sim-config reached sim_world only, and a changed camera gave poses scaled 2.7 times (a review).
SIM_CONFIG_FILE = ParameterSpec("sim_config_file", "", "with the sim_bands preset: the simulated robot's config YAML, "
                                "whose camera and bands are used, as sim_world's; '' = the package's config/sim.yaml",
                                read_only=True)
