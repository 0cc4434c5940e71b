"""rosbag2 (Jazzy) bags with MCAP storage: writing, reading, and the definitions and QoS they carry.

No rclpy import: the offline tools write bags without DDS.
"""

from .definitions import DefinitionError, MessageDefinition, message_definition
from .qos import BagQos
from .reader import BagMessage, BagReader, BagTopic, reindex
from .writer import BagError, BagWriter

__all__ = ["BagError", "BagMessage", "BagQos", "BagReader", "BagTopic", "BagWriter", "DefinitionError",
           "MessageDefinition", "message_definition", "reindex"]
