"""rosbag2 directories (``metadata.yaml`` + MCAP) written and read with ``rosbags``, no ROS install needed.

:class:`BagRecorder` takes messages already serialized as CDR (what rclpy's raw subscriptions give: the
bytes as they came over DDS) with their ROS type name, and writes them with the message definitions of
ROS 2 Jazzy's type store, so the bag opens in ``ros2 bag info`` / ``ros2 bag play``, Foxglove and
``rosbags`` alike. (``rclpy.serialization.serialize_message`` is not such bytes for every type: for a
JointState it adds 8 trailing bytes that rosbags' ``deserialize_cdr`` refuses as a size mismatch.) A topic
is added on its first message, so a bag holds exactly the topics that carried data (e.g.
``/sim/ground_truth_pose`` only on the simulated rig). :meth:`BagRecorder.close` (also on an exception, as
a context manager) finishes the files: what was recorded is kept.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from srs_ros.core.errors import ConfigurationError

#: rosbag2 metadata version written (Jazzy's rosbag2 reads 9).
BAG_VERSION = 9
#: The type store whose message definitions go into the bag.
TYPESTORE = Stores.ROS2_JAZZY


class BagRecorder:
    """One rosbag2 directory being written; ``write(topic, type_name, stamp_ns, cdr)`` per message."""

    def __init__(self, path: str | Path):
        """Create the bag directory ``path`` (it must not exist yet)."""
        self.path = Path(path)
        if self.path.exists():
            raise ConfigurationError(f"{self.path}: exists already; a bag is written into a new directory.")
        self._typestore = get_typestore(TYPESTORE)
        self._writer = Writer(self.path, version=BAG_VERSION, storage_plugin=StoragePlugin.MCAP)
        try:
            self._writer.open()
        except OSError as exc:  # a bare FileNotFoundError before (a helper's review)
            raise ConfigurationError(f"{self.path}: cannot create the bag directory ({exc.strerror or exc}); "
                                     "choose a writable folder.") from None
        self._connections: dict[str, object] = {}
        self.counts: dict[str, int] = {}
        self.closed = False

    def __enter__(self) -> BagRecorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def write(self, topic: str, type_name: str, stamp_ns: int, data: bytes,
              offered_qos: Callable[[], Sequence[Qos]] | None = None) -> None:
        """Add one CDR-serialized message of ``type_name`` (e.g. ``sensor_msgs/msg/JointState``) at ``stamp_ns``.

        ``offered_qos`` gives the QoS profiles of the topic's publishers (read once, at its first message), which
        rosbag2 keeps in ``metadata.yaml``: ``ros2 bag play`` replays a topic whose publishers all offered
        transient-local durability (the latched gait trajectory) as latched.
        """
        if self.closed:
            return
        connection = self._connections.get(topic)
        if connection is None:
            if type_name not in self._typestore.types:
                raise ConfigurationError(f"{topic}: message type {type_name!r} is not in the {TYPESTORE.name} "
                                         "type store; it cannot be recorded with its definition.")
            connection = self._writer.add_connection(topic, type_name, typestore=self._typestore,
                                                     offered_qos_profiles=tuple(offered_qos() if offered_qos else ()))
            self._connections[topic] = connection
            self.counts[topic] = 0
        self._writer.write(connection, int(stamp_ns), bytes(data))
        self.counts[topic] += 1

    def close(self) -> None:
        """Finish the MCAP file and ``metadata.yaml`` (idempotent)."""
        if not self.closed:
            self.closed = True
            self._writer.close()


#: An infinite duration as Jazzy's rosbag2 writes it: rmw's infinite, INT64_MAX ns, as seconds and nanoseconds (what
#: Fast DDS reports for a publisher's default deadline, lifespan and lease through get_publishers_info_by_topic).
INFINITE_TIME = QosTime(9223372036, 854775807)


def _bag_time(duration: Any) -> QosTime:
    return QosTime(*divmod(min(int(duration.nanoseconds), 2**63 - 1), 10**9))


def bag_qos(profile: Any) -> Qos:
    """An rclpy ``QoSProfile`` (a publisher's, as ``get_publishers_info_by_topic`` gives it) as rosbag2 records it.

    The policies' numbers are rmw's in both (rclpy's enums and rosbags' mirror them); read by attribute, so the
    recording needs no ROS import.
    """
    return Qos(QosHistory(int(profile.history)), int(profile.depth), QosReliability(int(profile.reliability)),
               QosDurability(int(profile.durability)), _bag_time(profile.deadline), _bag_time(profile.lifespan),
               QosLiveliness(int(profile.liveliness)), _bag_time(profile.liveliness_lease_duration),
               bool(profile.avoid_ros_namespace_conventions))


def bag_offered_qos(path: str | Path) -> dict[str, list[Qos]]:
    """Topic -> the offered QoS profiles recorded in a rosbag2 directory's metadata."""
    with Reader(Path(path)) as reader:
        return {connection.topic: list(connection.ext.offered_qos_profiles) for connection in reader.connections}


def bag_message_counts(path: str | Path) -> dict[str, int]:
    """Messages per topic of a rosbag2 directory (read with ``rosbags``)."""
    with Reader(Path(path)) as reader:
        return {connection.topic: connection.msgcount for connection in reader.connections}


def bag_topic_types(path: str | Path) -> Mapping[str, str]:
    """Topic -> message type of a rosbag2 directory."""
    with Reader(Path(path)) as reader:
        return {connection.topic: connection.msgtype for connection in reader.connections}
