"""ROS parameters of the srs_ros nodes: declared once per node from specs, integers taken as doubles, guarded."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Any

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.parameter import Parameter

from srs_ros.core.errors import ConfigurationError


@dataclass(frozen=True)
class ParameterSpec:
    """One declared parameter: default value, allowed range (inclusive) and description with unit."""

    name: str
    default: Any
    description: str
    minimum: float | int | None = None
    maximum: float | int | None = None
    read_only: bool = False
    additional_constraints: str = ""

    @property
    def is_double(self) -> bool:
        """True for a double parameter (a float default); it also accepts integers (:func:`declare_parameters`)."""
        return isinstance(self.default, float)

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
        """Empty string if ``value`` is acceptable, else the reason (what was wrong, what is allowed)."""
        expected = type(self.default)
        if expected is float and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)
        if not isinstance(value, expected) or (expected is not bool and isinstance(value, bool)):
            kind = "number (a double, e.g. 500.0)" if expected is float else expected.__name__
            return f"{self.name}: expected a {kind}, got {value!r}."
        if self.minimum is not None and self.maximum is not None and not isinstance(value, (bool, str)):
            if not (self.minimum <= value <= self.maximum):
                return f"{self.name}: {value} is outside [{self.minimum}, {self.maximum}] ({self.description})."
        return ""


def declare_parameters(node: Node, specs: Iterable[ParameterSpec]) -> dict[str, ParameterSpec]:
    """Declare every spec on ``node`` with its descriptor; return them by name. Once per node: all of them.

    A double parameter also takes an integer, converted to a double: at start-up
    (``-p rate_hz:=500``, a launch argument ``amplitude_bar:=3``) and at run time
    (``ros2 param set /gait_player rate_hz 500``). rclpy types parameters strictly and would refuse
    both; the value stored, published and checked against the range is always the double.

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
    doubles = frozenset(name for name, spec in by_name.items() if spec.is_double)
    # Start-up overrides are read by declare_parameter before any callback runs, so convert them here
    # (rclpy keeps them in Node._parameter_overrides and offers no public setter).
    overrides = getattr(node, "_parameter_overrides", {})
    for name in doubles & set(overrides):
        overrides[name] = integers_as_doubles(doubles, [overrides[name]])[0]
    for spec in by_name.values():
        node.declare_parameter(spec.name, spec.default, spec.descriptor())
    if doubles:
        node.add_pre_set_parameters_callback(partial(integers_as_doubles, doubles))
    return by_name


def startup_value(node: Node, spec: ParameterSpec) -> Any:
    """The value ``spec`` will be declared with: its start-up override (``-p``, a params file) or its default.

    For a node whose other parameters depend on one of them (e.g. a range from the robot file), read
    before the one :func:`declare_parameters` call. Raises ConfigurationError for a value of the wrong type.
    """
    override = getattr(node, "_parameter_overrides", {}).get(spec.name)
    value = spec.default if override is None else override.value
    reason = spec.check(value)
    if reason:
        raise ConfigurationError(f"invalid start-up parameter: {reason}")
    return float(value) if spec.is_double else value


def integers_as_doubles(names: frozenset[str], params: list[Parameter]) -> list[Parameter]:
    """``params`` with every integer value of a parameter in ``names`` turned into the equal double."""
    return [Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
            if p.name in names and p.type_ == Parameter.Type.INTEGER else p for p in params]


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
