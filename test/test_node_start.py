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
The node's start-up: what it says, and when its sample loop starts.

A free-running loop (``real_time_factor`` 0) starts after the constructor's log lines: it holds the
GIL between samples, and rclpy's logger makes hundreds of syscalls that each wait for it. A paced
loop starts before them (its first sample is due at once). Start-up overrides that name no
parameter get a warning naming them.
"""

from __future__ import annotations

import pytest
import rclpy
from rclpy.parameter import Parameter
from torquefree_ros.ros.node import TorqueFreeSim


class _SpiedLogger:
    """The node's logger, noting each line and whether the sample loop's thread ran by then."""

    def __init__(self, logger, node, lines: list):
        self._logger, self._node, self._lines = logger, node, lines

    def _note(self, severity: str, text: str) -> None:
        loop = self._node._loop
        self._lines.append((severity, text, loop is not None and loop.running))

    # one call of rclpy's logger per severity: it keys each call site to one severity
    def info(self, text):
        self._note('info', text)
        return self._logger.info(text)

    def warning(self, text):
        self._note('warning', text)
        return self._logger.warning(text)

    def error(self, text):
        self._note('error', text)
        return self._logger.error(text)


class _SpiedSim(TorqueFreeSim):

    def __init__(self, *args, **kwargs):
        self.lines: list = []
        super().__init__(*args, **kwargs)

    def get_logger(self):
        return _SpiedLogger(super().get_logger(), self, self.lines)


@pytest.fixture
def context():
    context = rclpy.Context()
    rclpy.init(context=context)
    yield context
    context.try_shutdown()


def _start(context, **parameters) -> _SpiedSim:
    overrides = [Parameter(name, value=value) for name, value in parameters.items()]
    return _SpiedSim(context=context, parameter_overrides=overrides)


@pytest.mark.parametrize(
    'parameters, free_running',
    [
        ({'real_time_factor': 0.0}, True),
        ({'real_time_factor': 1.0}, False),
        ({'real_time_factor': 0.0, 'scene': 'detumble', 'lockstep': True}, False),
    ],
)
def test_a_free_running_loop_starts_after_the_start_line_a_paced_one_before(
    context, parameters, free_running
):
    node = _start(context, **parameters)
    try:
        ((severity, text, running),) = [line for line in node.lines if 'start:' in line[1]]
        assert severity == 'info' and text.startswith('start: publishing')
        assert running is not free_running
        assert node.sample_loop.running  # either way, running once constructed
        assert node.sample_loop.request.free_running is free_running
    finally:
        node.destroy_node()


def test_start_up_overrides_naming_no_parameter_are_warned_of_by_name(context):
    node = _start(context, publish_rte=50.0, bogus=1, publish_rate=20.0)
    try:
        warnings = [text for severity, text, _ in node.lines if severity == 'warning']
        assert warnings == [
            "start-up parameter 'bogus' is not a parameter of this node, ignored",
            "start-up parameter 'publish_rte' is not a parameter of this node, ignored "
            '(did you mean publish_rate?)',
        ]
        assert node.get_parameter('publish_rate').value == 20.0
        assert node.sample_loop.running  # a warning, not a refusal
    finally:
        node.destroy_node()


def test_known_overrides_and_rclpy_own_parameters_raise_no_warning(context):
    node = _start(context, publish_rate=20.0, use_sim_time=False)
    try:
        assert [line for line in node.lines if line[0] == 'warning'] == []
    finally:
        node.destroy_node()


def test_the_node_process_runs_with_a_short_switch_interval(monkeypatch):
    """``torquefree_sim`` owns its process: the GIL changes hands within 0.5 ms, not 5."""
    import sys

    from torquefree_ros.cli import sim

    seen = []

    def node():
        seen.append(sys.getswitchinterval())
        raise KeyboardInterrupt

    monkeypatch.setattr(sim, 'init', lambda argv: None)
    monkeypatch.setattr(sim, 'SingleThreadedExecutor', lambda: None)
    monkeypatch.setattr(sim, 'TorqueFreeSim', node)
    monkeypatch.setattr(sim, 'shut_down', lambda *handles: None)
    previous = sys.getswitchinterval()
    try:
        assert sim.main(['torquefree_sim']) == 0
    finally:
        sys.setswitchinterval(previous)
    assert seen == [sim.SWITCH_INTERVAL] and sim.SWITCH_INTERVAL < previous
