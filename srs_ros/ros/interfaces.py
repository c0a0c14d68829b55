"""The ROS contract of srs_ros in one place: every topic name, QoS profile and message helper.

Topic graph (relative names, remappable with ``--ros-args -r``)::

    trajectory_server --gait_trajectory (JointTrajectory, reliable+transient_local)--> gait_player
    gait_player       --joint_setpoints (JointState, best effort)--> hardware_node
                      --gait_phase (JointState: the cycle's phase and signed frequency, best effort)--> navigator
    hardware_node     --commanded_pressure_bar / command_voltage_v (Float64MultiArray, labelled)
                      --actuator_state (JointState), /diagnostics (DiagnosticArray)
    hardware_node (sim backend) --sim/regulator_command--> sim_world --sim/regulator_monitor--> (back)
    sim_world         --sim/ground_truth_pose, sim/body_markers, image_raw, /clock (use_sim_time)
    camera_tracker    --robot_pose (PoseStamped), robot_twist (TwistStamped), robot_path (Path)
    navigator         <--goal_pose (PoseStamped), goal_path (Path), robot_pose; drives trajectory_server and
                      gait_player through their parameters and services; --navigation_progress (String, JSON,
                      reliable+transient_local), navigation_markers (MarkerArray, for RViz), /diagnostics

Nodes, backends, experiments, tests and benchmarks take names and profiles from here, never as literals.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from builtin_interfaces.msg import Duration, Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Point
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image, JointState
from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String
from visualization_msgs.msg import Marker

from srs_ros.core.errors import InvalidInputError
from srs_ros.core.vision.camera_calibration import DEFAULT_FRAME_ID

#: The opt-in Fast DDS profile (in config/) of node processes on one machine: a 16 MB shared-memory segment, so
#: that a 0.9 MB bgr8 camera image passes whole instead of in UDP fragments that a busy reader loses (see the
#: file). sim_world's default Bayer frames (0.3 MB) fit Fast DDS's default segment and do not need it.
DDS_PROFILE_FILE = "fastdds_camera_shm.xml"
#: The variable by which Fast DDS (ROS 2 Jazzy's default middleware) reads a process's default profile.
DDS_PROFILE_ENV = "FASTRTPS_DEFAULT_PROFILES_FILE"

TRAJECTORY_TOPIC = "gait_trajectory"
#: How trajectory_server's ``~/regenerate`` answers while another fit runs: a client may wait and call again.
FIT_BUSY_PREFIX = "busy:"
#: While trajectory_server is busy with another fit (its start-up fit, slow on a busy machine), a client asks again
#: this often (s).
BUSY_RETRY_S = 0.25


def fit_busy(message: str) -> bool:
    """True when a ``~/regenerate`` answer says trajectory_server is busy with another fit (:data:`FIT_BUSY_PREFIX`)."""
    return message.startswith(FIT_BUSY_PREFIX)


SETPOINT_TOPIC = "joint_setpoints"


#: gait_player's place in its cycle while it streams: sensor_msgs/JointState with one "joint"
#: (:data:`GAIT_PHASE_JOINT`): position = the phase in cycles [0, 1), velocity = the signed playback frequency
#: (cycles/s, negative while reversed), effort = the cycles played; stamp = the setpoint's. Best effort.
GAIT_PHASE_TOPIC = "gait_phase"
GAIT_PHASE_JOINT = "gait_phase"


COMMANDED_PRESSURE_TOPIC = "commanded_pressure_bar"


COMMAND_VOLTAGE_TOPIC = "command_voltage_v"


ACTUATOR_STATE_TOPIC = "actuator_state"


DIAGNOSTICS_TOPIC = "/diagnostics"


POSE_TOPIC = "robot_pose"


TWIST_TOPIC = "robot_twist"


PATH_TOPIC = "robot_path"


def latched_qos(depth: int = 1) -> QoSProfile:
    """Reliable + transient_local: late subscribers get the last message.

    ``ros2 topic echo`` needs ``--qos-durability transient_local`` to see it.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


def setpoint_qos(depth: int = 1) -> QoSProfile:
    """Best effort, volatile, depth 1: a stream where only the newest sample matters (no backlog after a stall)."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT,
                      durability=DurabilityPolicy.VOLATILE)


def gait_phase_message(stamp: Time, phase: float, frequency_hz: float, cycles_done: float) -> JointState:
    """A :data:`GAIT_PHASE_TOPIC` message."""
    msg = JointState(name=[GAIT_PHASE_JOINT], position=[float(phase)], velocity=[float(frequency_hz)],
                     effort=[float(cycles_done)])
    msg.header.stamp = stamp
    return msg


def labelled_array(labels: Sequence[str], values) -> Float64MultiArray:
    """A Float64MultiArray whose one dimension is labelled with the comma-joined joint names."""
    msg = Float64MultiArray()
    msg.layout.dim = [MultiArrayDimension(label=",".join(labels), size=len(labels), stride=len(labels))]
    msg.data = [float(v) for v in values]
    return msg


def joint_state(names: Sequence[str], stamp: Time, position=None, effort=None) -> JointState:
    """A JointState of ``names`` stamped ``stamp``; ``position`` and ``effort`` (one value a name) empty where None."""
    msg = JointState(name=list(names))
    msg.header.stamp = stamp
    if position is not None:
        msg.position = [float(v) for v in position]
    if effort is not None:
        msg.effort = [float(v) for v in effort]
    return msg


IMAGE_TOPIC = "image_raw"


_CHANNELS = {"bgr8": 3, "rgb8": 3, "mono8": 1, "8UC1": 1, "8UC3": 3, "bgra8": 4, "rgba8": 4,
             "bayer_rggb8": 1, "bayer_bggr8": 1, "bayer_gbrg8": 1, "bayer_grbg8": 1}
#: The channels, in BGR order, of the encodings that are not BGR already (NumPy indexing: no OpenCV import,
#: which cost every node 40-90 ms of start-up).
_TO_BGR = {"rgb8": [2, 1, 0], "bgra8": [0, 1, 2], "rgba8": [2, 1, 0]}
#: Where each colour sits in a Bayer mosaic's 2x2 tile, (row, column), for the encodings of sensor_msgs'
#: image_encodings.hpp: the name reads the tile's first row, then its second (``bayer_rggb8``: R G / G B).
BAYER_TILES = {
    "bayer_rggb8": {"r": (0, 0), "g": ((0, 1), (1, 0)), "b": (1, 1)},
    "bayer_bggr8": {"r": (1, 1), "g": ((0, 1), (1, 0)), "b": (0, 0)},
    "bayer_gbrg8": {"r": (1, 0), "g": ((0, 0), (1, 1)), "b": (0, 1)},
    "bayer_grbg8": {"r": (0, 1), "g": ((0, 0), (1, 1)), "b": (1, 0)},
}
#: OpenCV's demosaicing code of each (OpenCV names a pattern by the tile at the second row and column, so ROS's
#: ``bayer_rggb8`` is its ``BayerBG``; the same table as cv_bridge's).
_BAYER_TO_BGR_CODE = {"bayer_rggb8": "COLOR_BayerBG2BGR", "bayer_bggr8": "COLOR_BayerRG2BGR",
                      "bayer_gbrg8": "COLOR_BayerGR2BGR", "bayer_grbg8": "COLOR_BayerGB2BGR"}
#: The encodings :func:`array_to_image_msg` writes from a BGR image (a mono one is written as mono8).
IMAGE_ENCODINGS_OUT = ("bgr8", *BAYER_TILES)
#: The smallest side of a Bayer frame OpenCV demosaics (smaller ones come out black).
MIN_BAYER_SIDE_PX = 3


# ------------------------------------------------------------------------------------------
# sensor_msgs/Image <-> NumPy (no cv_bridge needed)
# ------------------------------------------------------------------------------------------
def image_msg_to_array(msg: Image) -> np.ndarray:
    """An Image message as a BGR (h, w, 3) or mono (h, w) uint8 array (a copy; row padding removed)."""
    channels = _CHANNELS.get(msg.encoding)
    if channels is None:
        raise InvalidInputError(
            f"image encoding {msg.encoding!r} is not supported; expected one of {sorted(_CHANNELS)}."
        )
    if msg.width == 0 or msg.height == 0:
        raise InvalidInputError(f"image {msg.width}x{msg.height} {msg.encoding} is empty; expected at least 1x1 "
                                "pixels.")
    row_bytes = msg.width * channels
    if msg.step < row_bytes or len(msg.data) < msg.step * msg.height:
        raise InvalidInputError(
            f"image {msg.width}x{msg.height} {msg.encoding}: step {msg.step} and {len(msg.data)} bytes are too small "
            f"(expected step >= {row_bytes} and {msg.step * msg.height} bytes)."
        )
    buffer = np.frombuffer(msg.data, dtype=np.uint8, count=msg.step * msg.height).reshape(msg.height, msg.step)
    pixels = buffer[:, :row_bytes].reshape(msg.height, msg.width, channels)
    if msg.encoding in _BAYER_TO_BGR_CODE:
        if min(msg.width, msg.height) < MIN_BAYER_SIDE_PX:
            raise InvalidInputError(f"image {msg.width}x{msg.height} {msg.encoding} is too small to demosaic; "
                                    f"expected at least {MIN_BAYER_SIDE_PX}x{MIN_BAYER_SIDE_PX} pixels.")
        return _demosaic(pixels[:, :, 0], msg.encoding)
    if channels == 1:
        return pixels[:, :, 0].copy()
    order = _TO_BGR.get(msg.encoding)
    return pixels.copy() if order is None else np.ascontiguousarray(pixels[:, :, order])


def array_to_image_msg(image: np.ndarray, stamp: Time | None = None, frame_id: str = "camera",
                       encoding: str | None = None) -> Image:
    """A BGR (h, w, 3) or mono (h, w) uint8 array as an Image message: bgr8 or mono8 unless ``encoding`` says.

    A BGR image may also be written as a colour camera's raw sensor would (``encoding="bayer_rggb8"`` or another
    of :data:`IMAGE_ENCODINGS_OUT`): one byte a pixel, the colour of the filter over it (a third of the bytes: a
    640x480 frame fits Fast DDS's default 512 KB shared-memory segment, where bgr8's 0.9 MB goes over UDP
    fragments that a busy reader loses).
    """
    image = np.ascontiguousarray(image)
    if image.dtype != np.uint8 or image.ndim not in (2, 3) or (image.ndim == 3 and image.shape[2] != 3):
        raise InvalidInputError(f"image {image.shape} {image.dtype}; expected uint8 (h, w) mono or (h, w, 3) BGR.")
    encoding = encoding or ("mono8" if image.ndim == 2 else "bgr8")
    allowed = ("mono8",) if image.ndim == 2 else IMAGE_ENCODINGS_OUT
    if encoding not in allowed:
        raise InvalidInputError(f"image {image.shape} cannot be written as {encoding!r}; expected one of "
                                f"{list(allowed)} for a {'mono (h, w)' if image.ndim == 2 else 'BGR (h, w, 3)'} "
                                "image.")
    if encoding in BAYER_TILES:
        image = _mosaic(image, encoding)
    msg = Image()
    if stamp is not None:
        msg.header.stamp = stamp
    msg.header.frame_id = frame_id
    msg.height, msg.width = image.shape[:2]
    msg.encoding = encoding
    msg.step = msg.width * (1 if image.ndim == 2 else 3)
    msg.data = image.tobytes()
    return msg


def _mosaic(bgr: np.ndarray, encoding: str) -> np.ndarray:
    """The Bayer mosaic of a BGR image: each pixel keeps the one colour its filter passes."""
    tile, raw = BAYER_TILES[encoding], np.empty(bgr.shape[:2], np.uint8)
    for channel, spots in ((2, [tile["r"]]), (1, tile["g"]), (0, [tile["b"]])):
        for row, column in spots:
            raw[row::2, column::2] = bgr[row::2, column::2, channel]
    return raw


def _demosaic(raw: np.ndarray, encoding: str) -> np.ndarray:
    """A Bayer mosaic as BGR, by OpenCV (imported here: only a node that receives one pays its start-up)."""
    import cv2

    return cv2.cvtColor(np.ascontiguousarray(raw), getattr(cv2, _BAYER_TO_BGR_CODE[encoding]))


# ------------------------------------------------------------------------------------------
# builtin_interfaces/Time and Duration <-> seconds and nanoseconds
# ------------------------------------------------------------------------------------------
_NS_PER_S = 1_000_000_000


def stamp_to_seconds(stamp: Time | Duration) -> float:
    """A builtin_interfaces/Time (or Duration) in seconds."""
    return stamp.sec + 1e-9 * stamp.nanosec


def stamp_to_nanoseconds(stamp: Time | Duration) -> int:
    """A builtin_interfaces/Time (or Duration) in integer nanoseconds (exact; 0 for an unstamped message)."""
    return stamp.sec * _NS_PER_S + stamp.nanosec


def nanoseconds_to_stamp(nanoseconds: int) -> Time:
    """Integer nanoseconds as a builtin_interfaces/Time (exact)."""
    sec, nanosec = divmod(int(nanoseconds), _NS_PER_S)
    return Time(sec=sec, nanosec=nanosec)


def nanoseconds_to_duration(nanoseconds: int) -> Duration:
    """Integer nanoseconds as a builtin_interfaces/Duration (exact), e.g. a trajectory point's time_from_start."""
    sec, nanosec = divmod(int(nanoseconds), _NS_PER_S)
    return Duration(sec=sec, nanosec=nanosec)


def seconds_to_stamp(seconds: float) -> Time:
    """Seconds as a builtin_interfaces/Time, to the nearest nanosecond."""
    return nanoseconds_to_stamp(round(seconds * _NS_PER_S))


# ------------------------------------------------------------------------------------------
# diagnostic_msgs: one status per report, levels by name as the ROS-free core says them
# ------------------------------------------------------------------------------------------
_LEVELS = {"OK": DiagnosticStatus.OK, "WARN": DiagnosticStatus.WARN, "ERROR": DiagnosticStatus.ERROR,
           "STALE": DiagnosticStatus.STALE}
#: The key of a status's value that gives the fully qualified name of the node reporting it (hardware_node's):
#: /diagnostics is shared by every robot on a domain, whatever namespace each runs in.
STATUS_NODE_KEY = "node"


def diagnostic_status(name: str, hardware_id: str, level: str, message: str,
                      values: Mapping[str, Any]) -> DiagnosticStatus:
    """A DiagnosticStatus at ``level`` (``"OK"``, ``"WARN"``, ``"ERROR"``, ``"STALE"``), each value as text."""
    if level not in _LEVELS:
        raise InvalidInputError(f"diagnostic level {level!r}; expected one of {list(_LEVELS)}.")
    return DiagnosticStatus(level=_LEVELS[level], name=name, message=message, hardware_id=hardware_id,
                            values=[KeyValue(key=key, value=str(value)) for key, value in values.items()])


def diagnostic_array(statuses: Sequence[DiagnosticStatus], stamp: Time) -> DiagnosticArray:
    """A DiagnosticArray of ``statuses`` stamped ``stamp``, ready for :data:`DIAGNOSTICS_TOPIC`."""
    msg = DiagnosticArray(status=list(statuses))
    msg.header.stamp = stamp
    return msg


def diagnostic_values(status: DiagnosticStatus) -> dict[str, str]:
    """A DiagnosticStatus's key/values as a dict."""
    return {pair.key: pair.value for pair in status.values}


GROUND_TRUTH_TOPIC = "sim/ground_truth_pose"


BODY_MARKERS_TOPIC = "sim/body_markers"


CLOCK_TOPIC = "/clock"


FLOOR_FRAME = DEFAULT_FRAME_ID


def floor_marker(marker_id: int, namespace: str, kind: int, rgba: Sequence[float], stamp: Time,
                 scale_m: Sequence[float] = (1.0, 1.0, 1.0), xyz_m: Sequence[float] = (0.0, 0.0, 0.0)) -> Marker:
    """An RViz marker of ``kind`` (``Marker.CYLINDER``, ``Marker.TEXT_VIEW_FACING``...) in :data:`FLOOR_FRAME`."""
    marker = Marker(id=marker_id, ns=namespace, type=kind, action=Marker.ADD)
    marker.header.stamp = stamp
    marker.header.frame_id = FLOOR_FRAME
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (float(v) for v in xyz_m)
    marker.pose.orientation.w = 1.0
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in scale_m)
    marker.color.r, marker.color.g, marker.color.b, marker.color.a = (float(c) for c in rgba)
    return marker


def line_strip_marker(marker_id: int, namespace: str, points_m, width_m: float, rgba: Sequence[float],
                      stamp: Time) -> Marker:
    """A line through ``points_m`` ((n, 3), or (n, 2) on the floor) in :data:`FLOOR_FRAME`, ``width_m`` wide."""
    points = np.asarray(points_m, dtype=float).reshape(len(points_m), -1) if len(points_m) else np.zeros((0, 3))
    if points.shape[1] == 2:
        points = np.column_stack([points, np.zeros(len(points))])
    marker = floor_marker(marker_id, namespace, Marker.LINE_STRIP, rgba, stamp, (width_m, 0.0, 0.0))
    marker.points = [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in points]
    return marker


SIM_COMMAND_TOPIC = "sim/regulator_command"


SIM_MONITOR_TOPIC = "sim/regulator_monitor"


#: How long (s of world time) sim_world's simulated board holds a command before it vents by itself. Longer
#: than a real board's 0.1 s (docs/can.md): a simulated rig shares an ordinary computer, whose processes stall
#: 0.2-0.4 s now and then; a real board runs on its own microcontroller.
SIM_BOARD_TIMEOUT_S = 0.5


def bus_qos():
    """The command 'bus': reliable, depth 1 (only the newest command matters, none is silently dropped)."""
    return _newest_only_qos(reliable=True)


def readback_qos():
    """A reader of a read-back stream: best effort, depth 1 (the newest sample; a lost one never holds up the next)."""
    return _newest_only_qos(reliable=False)


def _newest_only_qos(reliable: bool):
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1, durability=DurabilityPolicy.VOLATILE,
                      reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT)


# ------------------------------------------------------------------------------------------
# Navigation (the navigator node)
# ------------------------------------------------------------------------------------------
#: A goal: geometry_msgs/PoseStamped in the floor frame (what RViz's "2D Goal Pose" tool publishes on
#: /goal_pose); the orientation is ignored.
GOAL_POSE_TOPIC = "goal_pose"


#: Waypoints followed in order: nav_msgs/Path in the floor frame (orientations ignored).
GOAL_PATH_TOPIC = "goal_path"


#: The navigator's progress: std_msgs/String holding one JSON object (:func:`progress_message`), reliable and
#: transient_local (a late subscriber gets the current state at once).
NAVIGATION_PROGRESS_TOPIC = "navigation_progress"
#: What the navigator is doing, drawn for RViz (visualization_msgs/MarkerArray in :data:`FLOOR_FRAME`, reliable and
#: transient_local): the goal's tolerance disc, the waypoints ahead, the track driven and the state as text.
NAVIGATION_MARKERS_TOPIC = "navigation_markers"


def progress_message(fields: Mapping[str, Any]) -> String:
    """The navigator's progress as a std_msgs/String of one JSON object (keys sorted, floats as numbers).

    Read it back with :func:`progress_fields`; on a ROS install ``ros2 topic echo --qos-durability
    transient_local /navigation_progress`` shows it. NaN or inf (a quantity not known yet) is sent as null.
    """
    def plain(value: Any) -> Any:
        if isinstance(value, float) and not np.isfinite(value):
            return None
        if isinstance(value, (list, tuple)):
            return [plain(v) for v in value]
        if isinstance(value, Mapping):
            return {key: plain(v) for key, v in value.items()}
        return value

    return String(data=json.dumps({key: plain(value) for key, value in fields.items()}, sort_keys=True))


def progress_fields(msg: String) -> dict[str, Any]:
    """The fields of a :data:`NAVIGATION_PROGRESS_TOPIC` message (:class:`InvalidInputError` if it is not JSON)."""
    try:
        fields = json.loads(msg.data)
    except json.JSONDecodeError as exc:
        raise InvalidInputError(f"navigation progress {msg.data[:80]!r} is not JSON ({exc}); expected one JSON "
                                "object as the navigator publishes it.") from None
    if not isinstance(fields, dict):
        raise InvalidInputError(f"navigation progress {msg.data[:80]!r}; expected one JSON object.")
    return fields
