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
rclpy's parameter services, made safe against any request a DDS participant can send.

rclpy converts each ``rcl_interfaces/Parameter`` with ``Parameter.from_parameter_msg``, which
raises on an unknown type byte (``ValueError: 99 is not a valid Parameter.Type``); an exception in
a service callback ends the executor's spin, and with it the node. Here every request is answered:
a malformed parameter gets a refusal that says why, and an unexpected error an empty answer and a
log line.
"""

from __future__ import annotations

import functools

from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter
from rclpy.parameter_service import ParameterService

from ..files.safe_files import clip

MAX_NAME_LENGTH = 256  # characters of a parameter name; ours are a dozen
MAX_REASON_LENGTH = 400  # characters of a refusal sent back: one readable line, never megabytes


def refusal(reason: str) -> SetParametersResult:
    return SetParametersResult(successful=False, reason=clip(reason, MAX_REASON_LENGTH))


def parameter_from_message(message) -> Parameter:
    """
    Build a ``Parameter`` from its message, with the checks rclpy lacks.

    ``Parameter.from_parameter_msg`` with the checks it lacks; ``ValueError`` names the problem.
    """
    name = message.name
    if not name or len(name) > MAX_NAME_LENGTH:
        raise ValueError(
            f'{clip(name, 60)!r}: a parameter name has 1 to {MAX_NAME_LENGTH} characters'
        )
    try:
        Parameter.Type(message.value.type)
    except ValueError:
        raise ValueError(
            f'{name}: {message.value.type} is not a parameter type (rcl_interfaces/ParameterType)'
        ) from None
    return Parameter.from_parameter_msg(message)


class GuardedParameterService(ParameterService):
    """rclpy's ``ParameterService`` that answers every request (see the module's docstring)."""

    def __init__(self, node):
        self._logger = node.get_logger()
        super().__init__(node)

    def _set_parameters_callback(self, request, response):
        node = self._get_node()
        for message in request.parameters:
            try:
                result = node.set_parameters_atomically([parameter_from_message(message)])
            except (ValueError, ParameterNotDeclaredException) as error:
                result = refusal(str(error))
            response.results.append(result)
        return response

    def _set_parameters_atomically_callback(self, request, response):
        node = self._get_node()
        try:
            response.result = node.set_parameters_atomically(
                [parameter_from_message(m) for m in request.parameters]
            )
        except (ValueError, ParameterNotDeclaredException) as error:
            response.result = refusal(str(error))
        return response


def _answer_always(method):
    """Whatever goes wrong, the request is answered (possibly empty) and the node keeps running."""

    @functools.wraps(method)
    def guarded(self, request, response):
        try:
            return method(self, request, response)
        except Exception as error:  # noqa: BLE001 - a callback must not end the executor's spin
            self._logger.error(
                clip(
                    f'parameter request not served: {type(error).__name__}: {error}',
                    MAX_REASON_LENGTH,
                )
            )
            return type(response)()

    return guarded


for _name in (
    '_describe_parameters_callback',
    '_get_parameters_callback',
    '_get_parameter_types_callback',
    '_list_parameters_callback',
    '_set_parameters_callback',
    '_set_parameters_atomically_callback',
):
    setattr(
        GuardedParameterService, _name, _answer_always(getattr(GuardedParameterService, _name))
    )
