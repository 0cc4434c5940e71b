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
The attitude simulator node ``TorqueFreeSim`` (default name ``torquefree``; ``cli.sim`` runs it).

A thin layer over the dynamics core: parameters (``parameters``) describe a simulation, the
sample loop (``sample_loop``) publishes it, ``~/reset`` restarts it, ``~/pause`` pauses and resumes
it (the rule: ``pause``), ``/diagnostics`` reports it. The ``faults`` and ``sensor_noise``
parameters also change the running run from its next sample (``SampleLoop.retune``).
The node computes nothing physical itself.
"""

from __future__ import annotations

import difflib

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import QuaternionStamped, Vector3Stamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import InvalidParameterValueException
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rosgraph_msgs.msg import Clock
from std_srvs.srv import SetBool, Trigger

from .commands import command_diagnostics, CommandInputs
from .guarded_parameters import GuardedParameterService, MAX_REASON_LENGTH
from .parameters import (
    check_value,
    ConfigurationError,
    rejection,
    run_request,
    ScenePolicy,
    sensor_changes,
    SPEC_BY_NAME,
    SPECS,
)
from .pause import seconds_text
from .qos import message_class, publisher_warnings, sample_profile
from .sample_loop import RunRequest, SampleLoop, Stepping
from ..bag import BagError, BagWriter
from ..bag.samples import (
    ANGULAR_VELOCITY,
    ATTITUDE,
    CLOCK,
    INERTIA_KEY,
    sample_qos,
    SampleRecorder,
)
from ..bag.sensor_changes import SENSOR_CHANGES
from ..core.body.composite import tensor_elements
from ..files.safe_files import clip

DIAGNOSTICS_PERIOD = 1.0  # s
_INERTIA_CHANGED = 'torquefree_ros.inertia_changed_at_a_reset'
# The share of late samples above which /diagnostics reports a warning.
LATE_WARNING_FRACTION = 0.01


class _Publishers:
    """
    The node's sample publishers by topic.

    ``angular_velocity`` and ``attitude`` always, ``/clock`` from the first run that publishes it
    (a clock of our own, or ``publish_clock``), an output's topic only while a scene names it.
    """

    def __init__(self, node: Node, depth: int):
        self._node, self._depth = node, depth
        self.angular_velocity = self._create(Vector3Stamped, *ANGULAR_VELOCITY)
        self.attitude = self._create(QuaternionStamped, *ATTITUDE)
        self._by_topic = {ANGULAR_VELOCITY[0]: self.angular_velocity, ATTITUDE[0]: self.attitude}
        self._outputs: set[str] = set()

    def _create(self, message, topic: str, type_name: str):
        qos = sample_profile(self._depth, type_name)
        events = publisher_warnings(
            self._node.get_logger(), self._node.resolve_topic_name(topic), qos
        )
        return self._node.create_publisher(message, topic, qos, event_callbacks=events)

    def get(self, topic: str):
        return self._by_topic[topic]

    def resolved(self, topic: str) -> str:
        return self._by_topic[topic].topic_name

    def ensure(self, request: RunRequest) -> None:
        """Create what ``request`` publishes on (before the run starts)."""
        if request.clock and CLOCK[0] not in self._by_topic:
            self._by_topic[CLOCK[0]] = self._create(Clock, *CLOCK)
        for output in request.outputs:
            if output.topic not in self._by_topic:
                self._by_topic[output.topic] = self._create(
                    message_class(output.message_type), output.topic, output.message_type
                )
                self._outputs.add(output.topic)

    def topic_names(self) -> list[str]:
        """Every topic published now, resolved (``/angular_velocity``, ``/attitude``, ...)."""
        return [publisher.topic_name for publisher in self._by_topic.values()]

    def retire(self, request: RunRequest) -> None:
        """Destroy the output publishers ``request`` no longer uses (after the loop took it)."""
        for topic in self._outputs - {output.topic for output in request.outputs}:
            self._node.destroy_publisher(self._by_topic.pop(topic))
            self._outputs.discard(topic)


class TorqueFreeSim(Node):
    """
    The attitude simulator node: it publishes from the moment it is constructed.

    Publishes ``angular_velocity`` and ``attitude`` from the moment it is constructed; the
    caller spins it (services, parameters, diagnostics). Raises :class:`ConfigurationError` when
    the start-up parameters do not describe a usable simulation. ``stepped``: a sample goes out
    only when :attr:`stepping` lets it (``torquefree_ros.testing`` steps the node so).
    """

    def __init__(self, node_name: str = 'torquefree', *, stepped: bool = False, **node_options):
        # Undeclared names reach our on-set callback, whose reason names them (rclpy's does not).
        # rclpy's own parameter services end the spin on a malformed request; ours answer it
        super().__init__(
            node_name,
            allow_undeclared_parameters=True,
            start_parameter_services=False,
            **node_options,
        )
        self._declared = False
        self._loop: SampleLoop | None = None
        self._stepping: Stepping | None = None
        self._commands: CommandInputs | None = None
        self._bag: SampleRecorder | None = None
        try:
            self.add_on_set_parameters_callback(self._on_set_parameters)
            for spec in SPECS:
                self.declare_parameter(spec.name, spec.default, spec.descriptor())
            self._declared = True
            self._warn_unknown_overrides()
            self._scenes = ScenePolicy(
                self.get_parameter('scene').value, self.get_parameter('scene_directories').value
            )
            request = self._run_request()
        except InvalidParameterValueException as error:
            super().destroy_node()
            # rclpy's text is "Invalid parameter value (...) for parameter. Reason: REASON: NAME";
            # our reasons already start with the name
            reason = str(error).split('Reason: ', 1)[-1]
            name = f': {error.args[0].rsplit(": ", 1)[-1]}' if error.args else ''
            raise ConfigurationError(
                reason[: -len(name)] if name and reason.endswith(name) else reason
            ) from None
        except ValueError as error:
            super().destroy_node()
            raise ConfigurationError(str(error)) from None

        GuardedParameterService(self)
        depth = self.get_parameter('qos_depth').value
        writer = self._open_bag()
        self._outputs = _Publishers(self, depth)
        self._commands = CommandInputs(self, depth, self._command_holds, self._command_accepted)
        if writer is not None:
            self._bag = SampleRecorder(writer, self._resolved, sample_qos(depth))
        self._outputs.ensure(request)
        self._commands.ensure(request)
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        diagnostics_qos = QoSProfile(depth=10)
        self._diagnostics = self.create_publisher(
            DiagnosticArray,
            '/diagnostics',
            diagnostics_qos,
            event_callbacks=publisher_warnings(self.get_logger(), '/diagnostics', diagnostics_qos),
        )
        self.create_timer(DIAGNOSTICS_PERIOD, self._publish_diagnostics)
        self._loop = SampleLoop(
            self._outputs, self.context.ok, self.get_logger(), self._bag, stepped=stepped
        )
        self._stepping = Stepping(self._loop, self.resolve_topic_name)
        simulation = self._loop.prepare(request)
        if not request.free_running:
            self._loop.start()  # its first sample is due now
        self._note_inertia(simulation)
        topics = ', '.join(self._outputs.topic_names())
        commands = ', '.join(self._commands.topic_names())
        listening = ''
        if commands:
            listening = f'; taking commands on {commands}' + (
                ' in lock-step' if request.lockstep else ''
            )
        recording = (
            f'recording bag {self._bag.writer.path}' if self._bag is not None else 'not recording'
        )
        self.get_logger().info(
            f'start: publishing {topics}{listening}; {recording}; {request.configuration}; '
            f'{simulation.summary()}'
        )
        if request.left_out:
            self.get_logger().warning(request.left_out)
        if request.free_running:
            # after the log lines: rclpy's logger makes hundreds of syscalls (inspect, realpath),
            # each waiting up to 5 ms for the GIL while the loop runs free (seconds in all)
            self._loop.start()

    def _warn_unknown_overrides(self) -> None:
        """
        Warn of start-up overrides (``-p``, ``--params-file``) naming no parameter of the node.

        rclpy keeps them aside unused. A warning, not a refusal: a ``/**:`` parameter file shared
        by several nodes carries the others' keys too.
        """
        unknown = sorted(
            name for name in self._parameter_overrides if not self.has_parameter(name)
        )
        for name in unknown:
            close = difflib.get_close_matches(name, SPEC_BY_NAME, n=1)
            hint = f' (did you mean {close[0]}?)' if close else ''
            self.get_logger().warning(
                f'start-up parameter {name!r} is not a parameter of this node, ignored{hint}'
            )

    @property
    def sample_loop(self) -> SampleLoop:
        return self._loop

    @property
    def stepping(self) -> Stepping:
        """
        Return the interface a caller steps and follows the node through.

        ``torquefree_ros.testing`` uses this alone.
        """
        return self._stepping

    def _command_accepted(self) -> None:
        if self._loop is not None:
            # lock-step as fast as possible: the next sample goes out now
            self._loop.command_arrived()

    def _command_holds(self) -> tuple:
        simulation = self._loop.simulation if self._loop is not None else None
        return simulation.command_holds if simulation is not None else ()

    def _resolved(self, topic: str) -> str:
        if topic == SENSOR_CHANGES:
            return self.resolve_topic_name(topic)
        return self._commands.resolved(topic) or self._outputs.resolved(topic)

    def _open_bag(self) -> BagWriter | None:
        path = self.get_parameter('record_bag').value
        if not path:
            return None
        try:
            return BagWriter(
                path, custom_data={'torquefree_ros.node': self.get_fully_qualified_name()}
            )
        except BagError as error:
            super().destroy_node()
            raise ConfigurationError(f'record_bag: {error}') from None

    def _note_inertia(self, simulation) -> None:
        """
        Keep the body's inertia in the bag's metadata while it is the same for the whole recording.

        The bag stores the body's inertia (as torquefree_bag does) so that it can be plotted; a
        reset that changes the inertia removes it: no single value describes the recording then.
        """
        if self._bag is None:
            return
        custom = self._bag.writer.metadata.custom_data
        text = ' '.join(repr(x) for x in tensor_elements(simulation.body.tensor))
        if custom.get(INERTIA_KEY, text) == text and not custom.get(_INERTIA_CHANGED):
            custom[INERTIA_KEY] = text
        else:
            custom.pop(INERTIA_KEY, None)
            custom[_INERTIA_CHANGED] = 'true'

    def destroy_node(self):
        if self._commands is not None:
            self._commands.close()  # its thread first: it steps the loop in lock-step
        if self._loop is not None:
            self._loop.stop()
        if self._bag is not None:
            try:
                self._bag.writer.close()
                self.get_logger().info(
                    f'bag closed: {self._bag.writer.path} '
                    f'({self._bag.writer.message_count} messages)'
                )
            except BagError as error:
                self.get_logger().error(str(error))
            self._bag = None
        super().destroy_node()

    # -- parameters ------------------------------------------------------------------------------
    def _values(self, changes=()) -> dict:
        values = {
            spec.name: check_value(spec.name, self.get_parameter(spec.name)) for spec in SPECS
        }
        for parameter in changes:
            # rclpy's own parameters (use_sim_time) pass through
            if parameter.name in SPEC_BY_NAME:
                values[parameter.name] = check_value(parameter.name, parameter)
        return values

    def _run_request(self, changes=()) -> RunRequest:
        return run_request(self._values(changes))

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        try:
            for parameter in parameters:
                if parameter.name not in SPEC_BY_NAME and not self.has_parameter(parameter.name):
                    known = ', '.join(spec.name for spec in SPECS)
                    raise ValueError(
                        f'{clip(parameter.name, 60)}: not a parameter of this node '
                        f'(parameters: {known})'
                    )
            if self._declared:
                for parameter in parameters:
                    if parameter.name == 'scene':
                        self._scenes.check(check_value('scene', parameter))
                values = self._values(parameters)
                request = run_request(values)
                changed = [p.name for p in parameters if p.name in ('faults', 'sensor_noise')]
                if changed:
                    self._retune(values, request, ' and '.join(changed))
            else:  # declaring: the others are not there yet to form a whole configuration
                for parameter in parameters:
                    check_value(parameter.name, parameter)
        except ValueError as error:
            return rejection(error)
        except Exception as error:  # noqa: BLE001 - a callback must not end the node
            self.get_logger().error(
                clip(
                    f'parameters refused on an unexpected error: {type(error).__name__}: {error}',
                    MAX_REASON_LENGTH,
                )
            )
            return rejection(
                ValueError(
                    f'{parameters[0].name if parameters else "parameters"}: cannot be used '
                    f'({type(error).__name__})'
                )
            )
        return SetParametersResult(successful=True)

    def _retune(self, values: dict, request: RunRequest, names: str) -> None:
        """
        Put new ``faults`` and ``sensor_noise`` in force from the running run's next sample.

        Values that fit only the scene the next ``~/reset`` starts (another scene than the
        running one) take effect then, and the log says so; ``ValueError`` when they fit neither.
        """
        loop = self._loop
        if loop is None or not loop.running:
            return  # not started yet: the run it starts has them
        running = loop.request
        try:
            changes = sensor_changes(values, running, loop.simulation)
        except ValueError as error:
            if request.sensors.scene_outputs == running.sensors.scene_outputs:
                raise
            self.get_logger().warning(
                clip(
                    f'{names}: fits the scene of the next ~/reset, not the running one '
                    f'({error}); takes effect at the next ~/reset',
                    MAX_REASON_LENGTH,
                )
            )
            return
        try:
            k = loop.retune(changes)
        except RuntimeError as error:
            raise ValueError(f'{names}: not applied: {error}') from None
        self.get_logger().info(
            f'sensor changes from sample {k}: {len(changes.faults)} faults in force'
            + (f', {len(changes.outputs)} sensors retuned' if changes.outputs else '')
        )

    # -- reset -----------------------------------------------------------------------------------
    def _on_reset(self, request, response):
        try:
            run = self._run_request()
            self._outputs.ensure(run)
            self._commands.ensure(run)
            simulation = self._loop.restart(run)
        # ValueError: an unusable state; anything else must not end the node
        except Exception as error:  # noqa: BLE001 - a callback must not end the node
            self._outputs.retire(self._loop.request)
            self._commands.retire(self._loop.request)
            response.success = False
            reason = (
                str(error)
                if isinstance(error, (ValueError, RuntimeError))
                else f'{type(error).__name__}: {error}'
            )
            response.message = clip(
                f'reset refused, the running simulation continues unchanged: {reason}',
                MAX_REASON_LENGTH,
            )
            self.get_logger().warning(response.message)
            return response
        self._outputs.retire(run)
        self._commands.retire(run)
        self._note_inertia(simulation)
        response.success = True
        response.message = f'{run.configuration}; {simulation.summary()}'
        if self._loop.paused:
            response.message += '; paused: its sample 0 goes out when ~/pause false resumes' + (
                ' (its stamps then move on by the time paused)' if run.wall_clock else ''
            )
        self.get_logger().info(f'reset: {response.message}')
        if run.left_out:
            response.message += f'; {run.left_out}'
            self.get_logger().warning(run.left_out)
        return response

    # -- pause -----------------------------------------------------------------------------------
    def _on_pause(self, request, response):
        try:
            report = self._loop.pause(bool(request.data))
        except RuntimeError as error:
            response.success = False
            response.message = clip(
                f'{"pause" if request.data else "resume"} not done: {error}', MAX_REASON_LENGTH
            )
            self.get_logger().warning(response.message)
            return response
        response.success = True
        response.message = report.message()
        if report.changed:
            self.get_logger().info(response.message)
        return response

    # -- diagnostics -----------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        loop = self._loop
        simulation, last = loop.simulation, loop.last
        status = DiagnosticStatus(
            name=f'{self.get_name()}: simulation', hardware_id=self.get_fully_qualified_name()
        )
        values = {
            'propagator': simulation.propagator.describe(),
            # what the settings deliver, measured at the (re)start; the drifts below follow it live
            'accuracy': simulation.accuracy,
            'publish_rate': f'{simulation.rate:g}',
            'regime': simulation.regime.summary(),
            'effects': simulation.describe_effects(),
            'samples_published': str(loop.published),
            'late_samples': str(loop.late),
        }
        if last is not None and last.simulation is simulation:
            invariants = simulation.invariants(last.omega_B, last.internal)
            values.update(
                sim_time=repr(float(last.index / simulation.rate)),
                kinetic_energy=f'{invariants.kinetic_energy:.17g}',
                angular_momentum=f'{invariants.momentum:.17g}',
                kinetic_energy_drift=f'{invariants.energy_drift:.3g}',
                angular_momentum_drift=f'{invariants.momentum_drift:.3g}',
                # where the scene conserves a quantity its drift is the propagator's error
                conserved=', '.join(sorted(invariants.conserved))
                or 'none (the effects change both)',
            )
        command_values, command_warning = command_diagnostics(
            simulation.command_holds,
            last.index if last is not None and last.simulation is simulation else None,
            loop.missed_steps,
            loop.request.lockstep,
        )
        values.update(command_values)
        # the effects' own reports (reaction wheels: speeds, time limited, stored momentum)
        effect_values, effect_warning = simulation.monitor_diagnostics()
        values.update(effect_values)
        # the faults in force, and those acting on the last sample out
        values.update(
            simulation.fault_diagnostics(
                last.index if last is not None and last.simulation is simulation else None
            )
        )
        command_warning = '; '.join(w for w in (command_warning, effect_warning) if w)
        values['paused'] = 'true' if loop.paused else 'false'
        if loop.request.wall_clock:
            # how far pauses moved this run's wall-clock stamps (s): stamp = epoch + shift + t_k
            values['stamp_shift'] = seconds_text(loop.stamp_shift_ns)
        if self._bag is not None:
            values['record_bag'] = str(self._bag.writer.path)
            values['messages_recorded'] = str(self._bag.writer.message_count)
        if loop.failure:
            status.level, status.message = DiagnosticStatus.ERROR, loop.failure
        elif loop.recording_failure:
            status.level, status.message = (
                DiagnosticStatus.ERROR,
                f'recording stopped: {loop.recording_failure}',
            )
        elif command_warning:
            status.level, status.message = DiagnosticStatus.WARN, command_warning
        elif loop.late > LATE_WARNING_FRACTION * max(loop.published, 1):
            status.level, status.message = (
                DiagnosticStatus.WARN,
                'more than 1% of samples published late',
            )
        else:
            status.level, status.message = DiagnosticStatus.OK, 'running'
        if loop.paused:
            values['paused_at'] = loop.paused_at
            status.message = f'paused at {loop.paused_at}' + (
                '' if status.message == 'running' else f'; {status.message}'
            )
        status.values = [KeyValue(key=key, value=value) for key, value in values.items()]
        array = DiagnosticArray(status=[status])
        stamp = loop.clock_now_ns
        array.header.stamp.sec, array.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        self._diagnostics.publish(array)
