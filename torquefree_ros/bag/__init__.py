# Copyright 2026 torquefree_ros maintainers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
rosbag2 (Jazzy) bags with MCAP storage: writing, reading, and the definitions and QoS they carry.

No rclpy import: the offline tools write bags without DDS.
"""

from .definitions import DefinitionError, message_definition, MessageDefinition
from .files import BagError
from .qos import BagQos
from .reader import BagMessage, BagReader, BagTopic
from .writer import BagWriter, reindex

__all__ = [
    'BagError',
    'BagMessage',
    'BagQos',
    'BagReader',
    'BagTopic',
    'BagWriter',
    'DefinitionError',
    'MessageDefinition',
    'message_definition',
    'reindex',
]
