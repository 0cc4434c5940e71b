"""The simulator's samples in a bag: the same topics, types, QoS, stamps and bytes as the node
publishes, whether written by the node while it publishes or offline by ``torquefree_bag``."""

from __future__ import annotations

from .qos import BagQos
from .writer import BagWriter

ANGULAR_VELOCITY = ("angular_velocity", "geometry_msgs/msg/Vector3Stamped")
ATTITUDE = ("attitude", "geometry_msgs/msg/QuaternionStamped")
CLOCK = ("/clock", "rosgraph_msgs/msg/Clock")


def sample_qos(depth: int = 10) -> BagQos:
    """What the node's publishers offer: reliable, keep-last ``depth``, volatile, no deadline."""
    return BagQos(history="keep_last", depth=depth, reliability="reliable", durability="volatile")


def resolve_topic(name: str, namespace: str = "/") -> str:
    if name.startswith("/"):
        return name
    return namespace.rstrip("/") + "/" + name


class SampleRecorder:
    """Writes sample messages (already CDR-encoded) on the simulator's topics of ``writer``."""

    def __init__(self, writer: BagWriter, omega_topic: str, q_topic: str, qos: BagQos | None = None):
        """``omega_topic`` and ``q_topic``: the resolved (absolute) names the samples go out on."""
        self.writer = writer
        self._qos = (qos or sample_qos(),)
        self._omega = writer.add_topic(omega_topic, ANGULAR_VELOCITY[1], self._qos)
        self._q = writer.add_topic(q_topic, ATTITUDE[1], self._qos)
        self._clock: int | None = None

    @classmethod
    def in_namespace(cls, writer: BagWriter, namespace: str = "/", qos: BagQos | None = None) -> "SampleRecorder":
        return cls(writer, resolve_topic(ANGULAR_VELOCITY[0], namespace), resolve_topic(ATTITUDE[0], namespace), qos)

    def _clock_channel(self) -> int:
        if self._clock is None:
            self._clock = self.writer.add_topic(CLOCK[0], CLOCK[1], self._qos)
        return self._clock

    def write_block(self, stamps_ns, omega_messages, q_messages, clock_messages=None) -> None:
        """Sample ``i``: ``/clock`` (when given), then ``angular_velocity``, then ``attitude``, all
        logged at the sample's stamp, in the order the node publishes them."""
        if clock_messages is None:
            self.writer.write_rows((self._omega, self._q), stamps_ns, (omega_messages, q_messages))
        else:
            self.writer.write_rows((self._clock_channel(), self._omega, self._q), stamps_ns,
                                   (clock_messages, omega_messages, q_messages))

    def write_sample(self, stamp_ns: int, omega_message: bytes, q_message: bytes,
                     clock_message: bytes | None = None) -> None:
        self.write_block((stamp_ns,), (omega_message,), (q_message,),
                         None if clock_message is None else (clock_message,))
