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
The publishing loop of the simulator node, in a thread of its own.

It is the one place where the running simulation changes: a restart requested by the reset service
is applied between two samples, so no stamp ever carries a rate from one state and an attitude from
another. Samples are computed and CDR-encoded in vectorised blocks and published in stamp order.

Pacing: with ``real_time_factor == 1`` stamps are wall-clock time and sample ``k`` is published
when the wall clock reaches its stamp; a late loop catches up without skipping and counts the
samples it published more than one period after they were due. Any other factor runs a clock of our
own, published on ``/clock`` just before each sample (0 = as fast as possible).

Closed loop (a scene with ``torque_command`` or commanded ``reaction_wheels``): samples are
computed one at a time, when due, after the commands over the interval before them are sealed
(commands arriving later hold from the next interval); in lock-step the loop first waits for the
controller's answer to the last sample (a command stamped at or after it on every command topic),
at most ``lockstep_timeout`` wall seconds, and always runs on its own clock. The commands that hold
go into the bag, logged at the sample they hold from.

Lock-step as fast as possible (``real_time_factor`` 0): the thread that takes the answer (the
node's command inputs, ``ros.commands``) seals the interval, computes the next sample and
publishes it (:meth:`SampleLoop.command_arrived`) while the loop's thread waits for it: handing
each answer over to the loop's thread would cost a thread switch per round trip (``make
bench-lockstep`` measures both). The two threads take turns under one lock, and the loop's
thread alone applies restarts, pauses, failures and the missed answers' timeout. A lock-step
sample's rates (after ``/clock``) go out as soon as its state is computed; its outputs' rows are
computed, and its attitude and outputs encoded and published, after them: the controller works on
its answer meanwhile.

Pause (``pause(True)``, the node's ``~/pause``): taken between two samples, like a restart; from
then on no sample goes out and nothing is recorded, the simulated clock stands still (``/clock``,
when the run publishes it, is republished at its held value every ``HELD_CLOCK_PERIOD`` wall
seconds and not recorded), and a lock-step wait for the controller is interrupted. ``pause(False)``
resumes the same run: the samples that follow are those of a run never paused, with the same
indices and values. On a clock of our own the stamps simply continue (the clock held); with
wall-clock stamps the run's epoch moves on by the time paused (see :data:`.pause.WALL_CLOCK_RULE`).

Sensor changes (``retune(changes)``, the node's ``faults`` and ``sensor_noise`` parameters): taken
between two samples, like a restart; the next sample to go out and every one after it carry them
(the samples computed ahead are made again), and a recording loop writes them to the bag on
``sensor_changes``, logged at that sample's stamp (``bag.sensor_changes``), as it does at the start
of a run that has any.

Stepped (``stepped=True``): a sample goes out only once a caller has let it
(:meth:`SampleLoop.let_out`), on top of the rules above; meanwhile the loop waits between two
samples, taking restarts, pauses and a stop as usual. Sample 0 of every run waits too, so a caller
misses none. :class:`Stepping` is the whole of it a caller needs (``torquefree_ros.testing`` uses
nothing else): let samples out, take them back, and one consistent look at the run
(:class:`StepState`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
import threading
import time
from typing import Callable, NamedTuple

import numpy as np

from .pause import PauseReport, where
from ..bag.cdr import encode_times
from ..bag.samples import (
    ANGULAR_VELOCITY,
    ATTITUDE,
    CLOCK,
    encode_command,
    encode_leading,
    encode_trailing,
)
from ..bag.sensor_changes import encode_string, SENSOR_CHANGES, STRING
from ..bag.writer import BagError
from ..core.propagators import Propagator
from ..core.run.simulation import SampleBlock, Simulation
from ..core.timing.grid import restart_epoch_ns

# Samples computed ahead in one vectorised call: at most MAX_BLOCK, and at most this much wall time
# of samples (a reset discards the rest). When paced, the block is also kept small enough that
# computing it fits in one period, so it does not make the next sample late; as fast as possible,
# that computing it takes about BLOCK_WALL_SECONDS at most, so a reset or a stop never waits longer
# (see _Run.adapt).
MAX_BLOCK = 256
BLOCK_WALL_SECONDS = 0.25
#: the longest single wait for a deadline (s): the loop then checks again. A deadline can lie
#: beyond what a wait takes (a real_time_factor of 1e-300 puts the next sample centuries away)
MAX_WAIT = 1.0
#: while paused, /clock (when the run publishes it) goes out again at its held value this often
#: (wall s): a neighbour that starts during the pause learns the time, as under a paused Gazebo
HELD_CLOCK_PERIOD = 0.1


@dataclass(frozen=True)
class SensorChanges:
    """The faults and sensor noise of a run beyond its scene's, or a change of them."""

    faults: tuple = ()  # in force: the scene's, then the faults parameter's (core.faults.Fault)
    scene_faults: tuple = ()
    scene_outputs: tuple = ()  # the scene's outputs, before sensor_noise
    record: str = ''  # what the bag gets on sensor_changes ('': nothing to record)
    outputs: dict = dataclasses.field(default_factory=dict)  # a change: position -> sensor


@dataclass(frozen=True)
class RunRequest:
    propagator: Propagator
    publish_rate: float
    real_time_factor: float
    body_frame: str
    inertial_frame: str
    outputs: tuple = ()  # the scene's output effects: each publishes one more topic
    configuration: str = ''  # which scene and which parameter overrides describe this run
    left_out: str = ''  # the scene's outputs this Python cannot publish, and why ("" when none)
    lockstep: bool = False  # wait for the controller's answer to each sample (a clock of our own)
    # wall s to wait for it before going on with the command in force
    lockstep_timeout: float = 1.0
    # /clock with wall-clock stamps too (a clock of our own always has it)
    publish_clock: bool = False
    # where tf, pose, odometry and markers place the body (m, inertial)
    body_position: tuple = (0.0, 0.0, 0.0)
    sensors: SensorChanges = SensorChanges()  # faults and sensor noise beyond the scene's

    @property
    def wall_clock(self) -> bool:
        return self.real_time_factor == 1.0 and not self.lockstep

    @property
    def free_running(self) -> bool:
        """
        Whether the loop computes and publishes without ever waiting (as fast as possible).

        Such a loop holds the GIL between samples, so another thread of the process waits up to
        the interpreter's switch interval (5 ms) each time it takes the GIL back after a blocking
        call.
        """
        return self.real_time_factor == 0.0 and not self.lockstep

    @property
    def clock(self) -> bool:
        """
        Whether the run publishes ``/clock``.

        One message per sample, at its stamp, just before it.
        """
        return self.publish_clock or not self.wall_clock


class LastSample(NamedTuple):
    simulation: Simulation
    index: int
    stamp_ns: int
    omega_B: np.ndarray
    internal: np.ndarray  # the effects' own states


class _Run:
    """A started simulation with its pacing and its encoded block."""

    def __init__(self, request: RunRequest, simulation: Simulation):
        self.request = request
        self.simulation = simulation
        self.wall_ref_ns = time.time_ns()
        self.mono_ref = time.monotonic()
        self.period_wall = (
            1.0 / (request.publish_rate * request.real_time_factor)
            if request.real_time_factor
            else 0.0
        )
        samples_per_wall_second = request.publish_rate * (request.real_time_factor or float('inf'))
        self.max_block = int(
            min(MAX_BLOCK, max(1.0, samples_per_wall_second * BLOCK_WALL_SECONDS))
        )
        # Start with a one-sample block: paced, its cost is the fixed cost of a block; as fast as
        # possible, blocks then double while they stay well inside BLOCK_WALL_SECONDS.
        self.block_size = 1
        self.fixed_cost: float | None = None
        self.sample_cost: float | None = None
        self.next_index = 0
        self.block: SampleBlock | None = None
        self.columns: tuple = ()  # bag.samples.SampleColumn per topic, in publishing order
        self.leading_only = False  # the block's trailing columns are still to come (complete())
        self.position = 0
        self.holds = simulation.command_holds  # closed loop: (effect, hold) per command input
        self.shift_ns = 0  # wall clock: how far pauses moved the run's stamps (its epoch) in all
        self.publishers: list = []  # of self.columns' topics
        # lock-step: why the command thread could not compute the next sample
        self.stopped_by = ''
        if self.holds:
            # each sample computed when due, under the commands received by then
            self.max_block = 1
            for effect, hold in self.holds:
                hold.frame_id = effect.frame_id(request.body_frame, request.inertial_frame)

    @property
    def answered_in_turn(self) -> bool:
        """Lock-step as fast as possible: the answer's callback computes the next sample."""
        return self.request.lockstep and self.request.real_time_factor == 0.0

    def answered(self) -> bool:
        """Lock-step: every hold has the controller's answer to the last sample out."""
        answer = self.simulation.stamp_ns(self.next_index - 1)
        return all(hold.answered(answer) for _, hold in self.holds)

    @property
    def next_out(self) -> int:
        """Return the index of the next sample to go out."""
        return self.block.first + self.position if self.block is not None else self.next_index

    def resume(self, paused_ns: int) -> None:
        """
        Continue after ``paused_ns`` (monotonic) paused.

        A clock of our own held: only the pacing moves on. Wall-clock stamps: the run's epoch moves
        on by the time paused, and with it the stamps of the samples computed ahead (re-encoded
        from the same values), the command holds' grid and the commands in force (so a command's
        timeout counts simulated time, which stood still).
        """
        if not self.request.wall_clock:
            self.mono_ref += paused_ns * 1e-9
            return
        self.simulation.epoch_ns += paused_ns
        for _, hold in self.holds:
            hold.shift(paused_ns)
        if self.block is not None and self.position < len(self.block):
            self.block = dataclasses.replace(
                self.block, stamps_ns=self.block.stamps_ns + np.int64(paused_ns)
            )
            self.columns = self.encode(self.block)
        self.shift_ns += paused_ns

    def encode(self, block: SampleBlock) -> tuple:
        """Encode every column of ``block`` (its outputs' rows included), in publishing order."""
        return self.leading(block) + self.trailing(block)

    def leading(self, block: SampleBlock) -> tuple:
        return encode_leading(block, self.request.body_frame, self.request.clock)

    def trailing(self, block: SampleBlock) -> tuple:
        request = self.request
        return encode_trailing(
            block,
            request.body_frame,
            request.inertial_frame,
            self.simulation.outputs,
            request.body_position,
        )

    def retune(self, changes: SensorChanges) -> int:
        """
        Put ``changes`` in force from the next sample out; return its index.

        The samples of the block not yet out are made again (their outputs) and encoded.
        """
        k = self.next_out
        self.simulation.retune(k, changes.faults, changes.outputs)
        self.request = dataclasses.replace(
            self.request,
            outputs=self.simulation.outputs,
            sensors=dataclasses.replace(changes, outputs={}),
        )
        block = self.block
        if block is not None and self.position < len(block) and not self.leading_only:
            self.block = self.simulation.refaulted(block)
            self.columns = self.encode(self.block)
        return k

    def complete(self) -> tuple:
        """
        Add the outputs' rows and the trailing columns to a block refilled ``leading_only``.

        Return the columns added.
        """
        self.block = self.simulation.with_outputs(self.block)
        trailing = self.trailing(self.block)
        self.columns += trailing
        self.leading_only = False
        return trailing

    def deadline(self, stamp_ns: int) -> float | None:
        """Monotonic time at which the sample is due, or None when not paced."""
        if self.request.wall_clock:
            return self.mono_ref + (stamp_ns - self.wall_ref_ns) * 1e-9
        if self.request.real_time_factor == 0.0:
            return None
        return (
            self.mono_ref
            + (stamp_ns - self.simulation.epoch_ns) * 1e-9 / self.request.real_time_factor
        )

    def refill(self, leading_only: bool = False) -> None:
        """
        Compute and encode the next block.

        ``leading_only`` (one sample of a closed loop): only the columns of
        :func:`~torquefree_ros.bag.samples.encode_leading`, the rest left for :meth:`complete`.
        """
        started = time.perf_counter()
        block = self.simulation.samples(self.next_index, self.block_size, outputs=not leading_only)
        self.columns = self.leading(block) if leading_only else self.encode(block)
        self.leading_only = leading_only
        self.block = block
        self.next_index += len(block)
        self.position = 0
        cost = time.perf_counter() - started
        if self.holds:
            return
        if self.period_wall:
            self.adapt(len(block), cost)
        else:
            fitting = BLOCK_WALL_SECONDS * len(block) / max(cost, 1e-9)
            self.block_size = int(min(self.max_block, 2 * len(block), max(1.0, fitting)))

    def adapt(self, size: int, cost: float) -> None:
        """
        Model a block's cost as fixed + size * per_sample, and size the next block from it.

        The largest block whose cost fits in one period delays no sample past its period; if even
        the fixed cost does not fit, every block delays one sample whatever its size, so the
        largest block makes the fewest late.
        """
        if self.fixed_cost is None:
            self.fixed_cost = cost
        elif size > 1:
            per_sample = max(0.0, (cost - self.fixed_cost) / (size - 1))
            self.sample_cost = (
                per_sample
                if self.sample_cost is None
                else 0.8 * self.sample_cost + 0.2 * per_sample
            )
        slack = self.period_wall - self.fixed_cost
        if slack <= 0.0 or not self.sample_cost:
            self.block_size = self.max_block
        else:
            self.block_size = int(min(self.max_block, max(1.0, slack / self.sample_cost)))


class SampleLoop:
    """
    The loop that publishes a run's samples from its own thread.

    Publishes ``angular_velocity``, ``attitude``, the scene's outputs (and ``/clock``) from its
    own thread.

    ``publishers.get(topic)`` gives the publisher of each topic a run publishes; the caller creates
    them before it starts or restarts a run that needs them.
    ``keep_going()`` is false once the ROS context shuts down; publishing then stops quietly.
    ``recorder`` (a ``bag.samples.SampleRecorder``), when given, gets every sample right after it
    is published, with the same bytes; if the bag fails, recording stops and publishing goes on.
    """

    def __init__(
        self,
        publishers,
        keep_going: Callable[[], bool],
        logger,
        recorder=None,
        stepped: bool = False,
    ):
        self._publishers = publishers
        self._recorder = recorder
        self.recording_failure = ''
        self._keep_going = keep_going
        self._logger = logger
        self._lock = threading.Lock()
        self._wake = threading.Event()
        self._pending: tuple[RunRequest, threading.Event, list] | None = None
        self._stopping = False
        self._run: _Run | None = None
        self._thread: threading.Thread | None = None
        self.last: LastSample | None = None
        self.published = 0
        self.late = 0
        self.missed_steps = 0  # lock-step: samples computed without the controller's answer
        self.failure = ''
        self._pause_request: tuple[bool, threading.Event, list] | None = None
        self._retune_request: tuple[SensorChanges, threading.Event, list] | None = None
        self._paused_since_ns: int | None = None  # monotonic; None: running
        # while paused: the sample that goes out next, as "sample k (t = ... s)"
        self.paused_at = ''
        self._clock_ns: int | None = None  # the last /clock value published
        # lock-step as fast as possible: whoever computes a sample holds _turn; the loop's thread
        # sets _awaiting (the run) while it waits on _turn for the answer to the last sample, due
        # by _answer_due
        self._turn = threading.Condition()
        self._awaiting: _Run | None = None
        self._answer_due = 0.0
        # stepped: how many more samples may go out (let_out() adds, each sample sent takes one,
        # hold() takes back the rest); None: not stepped
        self._steps: int | None = 0 if stepped else None

    # -- called from the executor thread ---------------------------------------------------------
    def prepare(self, request: RunRequest) -> Simulation:
        """Make ``request`` the run :meth:`start` publishes; return its simulation."""
        self._run = self._begin(request)
        return self._run.simulation

    def start(self, request: RunRequest | None = None) -> Simulation:
        """Start the loop's thread on ``request`` (None: the run :meth:`prepare` made)."""
        if request is not None:
            self.prepare(request)
        self._thread = threading.Thread(target=self._main, name='torquefree_samples', daemon=True)
        self._thread.start()
        return self._run.simulation

    def restart(self, request: RunRequest, timeout: float = 10.0) -> Simulation:
        """
        Apply ``request`` between two samples; return the new simulation once it is running.

        While paused, it returns once the new simulation is in place: it starts paused, and its
        sample 0 goes out on resuming.
        """
        done, result = threading.Event(), []
        with self._lock:
            if self._stopping or not self.running:
                raise RuntimeError('the sample loop is not running')
            self._pending = (request, done, result)
        self._signal()
        if not done.wait(timeout):
            raise RuntimeError(f'the sample loop did not take the restart within {timeout:g} s')
        return result[0]

    def pause(self, paused: bool, timeout: float = 10.0) -> PauseReport:
        """
        Pause (True) or resume (False) between two samples; return once the loop has done it.

        From then on, while paused, no sample goes out.
        """
        done, result = threading.Event(), []
        with self._lock:
            if self._stopping or not self.running:
                raise RuntimeError('the sample loop is not running')
            self._pause_request = (bool(paused), done, result)
        self._signal()
        if not done.wait(timeout):
            raise RuntimeError(
                f'the sample loop did not take the {"pause" if paused else "resume"} within '
                f'{timeout:g} s; it applies at the next sample'
            )
        return result[0]

    def retune(self, changes: SensorChanges, timeout: float = 10.0) -> int:
        """
        Put sensor ``changes`` in force between two samples; return the first sample they reach.

        Returns once the loop has done it: the next sample out carries them.
        """
        done, result = threading.Event(), []
        with self._lock:
            if self._stopping or not self.running:
                raise RuntimeError('the sample loop is not running')
            self._retune_request = (changes, done, result)
        self._signal()
        if not done.wait(timeout):
            raise RuntimeError(f'the sample loop did not take the change within {timeout:g} s')
        if not result:
            raise RuntimeError('the sample loop failed applying the change (see its failure)')
        return result[0]

    def command_arrived(self) -> None:
        """
        Handle a command that went into its hold (called on the command inputs' thread).

        In lock-step as fast as possible, if the command answers the sample the loop waits on, the
        next sample is computed and published here and now (see the module's docstring).
        """
        if self._awaiting is None:  # (read again under the lock)
            return
        with self._turn:
            run = self._awaiting
            if (
                run is None
                or run.stopped_by  # (the answer to a sample whose outputs failed)
                or self._wake.is_set()
                or self._steps == 0
                or not run.answered()
            ):
                return
            try:
                self._step(run)
            # not raised to the command thread: the loop's thread reports it
            except Exception as error:  # noqa: BLE001 - the loop's thread reports it
                if self._stopping or not self._keep_going():
                    return
                run.stopped_by = f'{type(error).__name__}: {error}'
            if run.stopped_by:
                self._turn.notify_all()

    def let_out(self, count: int) -> None:
        """Let ``count`` (>= 0) more samples go out of a stepped loop."""
        if count < 0:
            raise ValueError(f'let_out: count must be >= 0, got {count}')
        with self._lock:
            if self._steps is None:
                raise RuntimeError('the sample loop is not stepped')
            self._steps += int(count)
            # lock-step: the wait for the answer starts now (the loop was held)
            if self._run is not None:
                self._answer_due = time.monotonic() + self._run.request.lockstep_timeout
        self._signal()

    def hold(self) -> None:
        """Take back every sample a stepped loop was let send and has not sent yet."""
        with self._lock:
            if self._steps is None:
                raise RuntimeError('the sample loop is not stepped')
            self._steps = 0
        # the signal ends a lock-step wait for an answer, after which the loop would send
        self._signal()

    @property
    def paused(self) -> bool:
        return self._paused_since_ns is not None

    @property
    def stamp_shift_ns(self) -> int:
        """How far pauses moved the running run's wall-clock stamps (0 on a clock of our own)."""
        return self._run.shift_ns if self._run else 0

    def stop(self, timeout: float = 5.0) -> None:
        with self._lock:
            self._stopping = True
        self._signal()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout)

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    @property
    def request(self) -> RunRequest | None:
        return self._run.request if self._run else None

    @property
    def simulation(self) -> Simulation | None:
        return self._run.simulation if self._run else None

    @property
    def last_stamp_ns(self) -> int | None:
        last = self.last
        return last.stamp_ns if last is not None else None

    @property
    def clock_now_ns(self) -> int:
        """Now on the clock the stamps come from."""
        run = self._run
        if run is None or run.request.wall_clock:
            return time.time_ns()
        last = self.last_stamp_ns
        return last if last is not None else run.simulation.epoch_ns

    # -- the loop thread -------------------------------------------------------------------------
    def _begin(self, request: RunRequest) -> _Run:
        last = self.last_stamp_ns
        now = time.time_ns() if request.wall_clock else (last or 0)
        epoch = restart_epoch_ns(now, last, request.publish_rate)
        simulation = Simulation(
            request.propagator,
            request.publish_rate,
            epoch,
            rate_name='publish_rate',
            outputs=request.outputs,
            faults=request.sensors.faults,
        )
        self.failure = ''
        self.missed_steps = 0
        run = _Run(request, simulation)
        for effect, _ in run.holds:  # command topics are in the bag from the run that takes them
            if self._recorder is not None:
                self._to_bag(lambda recorder: recorder.declare(effect.topic, effect.message_type))
        if request.sensors.record:
            self._record_sensors(simulation.epoch_ns, request.sensors.record)
        return run

    def _take_pending(self) -> bool:
        """Apply a pending restart (True when there was one), then a pending pause or resume."""
        with self._lock:
            if self._stopping:
                raise _Stop
            pending, self._pending = self._pending, None
            pause, self._pause_request = self._pause_request, None
            retune, self._retune_request = self._retune_request, None
        if pending is not None:
            request, done, result = pending
            self._run = self._begin(request)
            if self.paused:  # the new run starts paused: its pause counts from here
                self._paused_since_ns = time.monotonic_ns()
                self.paused_at = where(0, self._run.simulation.rate)
            result.append(self._run.simulation)
            done.set()
        if retune is not None:
            changes, done, result = retune
            run = self._run
            try:  # a failure to compute the outputs again stops the loop as any sample's does
                k = run.retune(changes)
                if run.block is not None and run.position < len(run.block):
                    run.publishers = [self._publishers.get(c.topic) for c in run.columns]
                if changes.record:
                    self._record_sensors(run.simulation.stamp_ns(k), changes.record)
                result.append(k)
            finally:
                done.set()
        if pause is not None:
            wanted, done, result = pause
            result.append(self._apply_pause(wanted))
            done.set()
        return pending is not None

    def _apply_pause(self, wanted: bool) -> PauseReport:
        run, now = self._run, time.monotonic_ns()
        changed = wanted != self.paused
        paused_for = now - self._paused_since_ns if self.paused else 0
        if changed and wanted:
            self.paused_at = where(run.next_out, run.simulation.rate)
            self._paused_since_ns = now
            if self._recorder is not None:  # the open chunk goes out now, not after the pause
                self._to_bag(lambda recorder: recorder.writer.flush())
        elif changed:
            self._paused_since_ns = None
            run.resume(paused_for)
            # the wait starts again
            self._answer_due = time.monotonic() + run.request.lockstep_timeout
        report = PauseReport(
            changed=changed,
            paused=wanted,
            next_index=run.next_out,
            rate=run.simulation.rate,
            clock_ns=self._clock_ns if run.request.clock else None,
            paused_for_ns=paused_for,
            wall_clock=run.request.wall_clock,
            total_shift_ns=run.shift_ns,
        )
        if changed and not wanted:
            self.paused_at = ''
        return report

    def _while_paused(self) -> None:
        """Until resumed (restarts may come meanwhile): no sample; the held /clock now and then."""
        next_clock = 0.0
        while True:
            self._take_pending()
            if not self.paused:
                return
            clock = self._run.request.clock
            if clock and self._clock_ns is not None and time.monotonic() >= next_clock:
                self._publishers.get(CLOCK[0]).publish(encode_times([self._clock_ns])[0])
                next_clock = time.monotonic() + HELD_CLOCK_PERIOD
            if self._wake.wait(HELD_CLOCK_PERIOD if clock else MAX_WAIT):
                self._wake.clear()

    def _main(self) -> None:
        try:
            self._loop()
        except _Stop:
            pass
        except Exception as error:  # noqa: BLE001 - reported, and the node stays up for a reset
            if self._stopping or not self._keep_going():
                return
            self.failure = f'{type(error).__name__}: {error}'
            self._logger.error(f'sample loop stopped: {self.failure}')

    def _loop(self) -> None:
        while True:
            self._take_pending()
            if self.paused:
                self._while_paused()
                continue
            # stepped, and no sample let out yet: wait for let_out() (or a request)
            if self._steps == 0:
                if self._wake.wait(MAX_WAIT):
                    self._wake.clear()
                continue
            run = self._run
            if run.holds and run.answered_in_turn:
                self._lockstep_turn(run)
                continue
            if run.block is None or run.position == len(run.block):
                if run.holds and not self._close_interval(run):
                    continue  # a restart or a stop is pending, or the sample is not due yet
                if not self._refill(run):
                    self._fail(run.stopped_by)
                    continue
            stamp = int(run.block.stamps_ns[run.position])
            deadline = run.deadline(stamp)
            if deadline is not None:
                delay = deadline - time.monotonic()
                if delay > 0.0:
                    if self._wake.wait(min(delay, MAX_WAIT)):
                        self._wake.clear()
                    continue  # re-check for a restart or a stop, then for the deadline
                if -delay > run.period_wall:
                    self.late += 1
            self._send(run)

    def _refill(self, run: _Run, leading_only: bool = False) -> bool:
        """
        Compute and encode the next block (``leading_only``: see :meth:`_Run.refill`).

        Return False (the reason in ``run.stopped_by``) when it cannot be.
        """
        try:
            run.refill(leading_only)
        except (ValueError, ArithmeticError, RuntimeError) as error:  # RuntimeError: a step bound
            run.stopped_by = f'cannot compute samples {run.next_index}..: {error}'
            return False
        run.publishers = [self._publishers.get(column.topic) for column in run.columns]
        return True

    def _send(self, run: _Run) -> None:
        """
        Publish (and record) the block's next sample.

        A block refilled ``leading_only`` is completed between its leading and trailing columns.
        """
        i = run.position
        _publish(run.publishers, run.columns, i)
        if run.leading_only:
            try:
                trailing = run.complete()
            except (ValueError, ArithmeticError, RuntimeError) as error:
                run.stopped_by = f'cannot compute the outputs of sample {run.next_out}: {error}'
                run.block = None  # no half-sent block left behind (a pause would re-encode it)
                return
            publishers = [self._publishers.get(column.topic) for column in trailing]
            run.publishers += publishers
            _publish(publishers, trailing, i)
        block = run.block
        stamp = int(block.stamps_ns[i])
        if self._recorder is not None:
            self._record(stamp, run.columns, i)
        if run.request.clock:
            self._clock_ns = stamp
        run.position = i + 1
        self.published += 1
        if self._steps is not None:
            with self._lock:
                self._steps = max(0, self._steps - 1)
        self.last = LastSample(
            run.simulation, block.first + i, stamp, block.omega_B[i], block.internal[i]
        )

    def _lockstep_turn(self, run: _Run) -> None:
        """
        Take one turn of lock-step as fast as possible, on the loop's thread.

        Wait (on ``_turn``) for the answer to the last sample; the answer's callback computes and
        publishes the next one meanwhile, unless the answer came before the wait or does not come
        within ``lockstep_timeout`` (a missed step): then this thread does. Returns after one
        sample, or early for a pending request or a failure.
        """
        if run.stopped_by:
            self._fail(run.stopped_by)
            return
        with self._turn:
            n = run.next_index
            if n > 0:
                self._awaiting = run
                try:
                    while True:
                        if run.next_index != n or run.stopped_by:
                            # the callback computed it (or could not): start over from the top
                            return
                        if self._wake.is_set():
                            self._wake.clear()
                            return  # a restart, a pause or a stop: applied between two samples
                        if run.answered():
                            break
                        remaining = self._answer_due - time.monotonic()
                        if remaining <= 0.0:
                            self.missed_steps += 1
                            break
                        self._turn.wait(min(remaining, MAX_WAIT))
                finally:
                    self._awaiting = None
            self._step(run)

    def _step(self, run: _Run) -> None:
        """
        Step the closed loop by one sample: seal the interval before it, compute it, publish it.

        Called under ``_turn``.
        """
        n = run.next_index
        if n > 0:
            self._seal(run, n - 1)
        # the rates go out before the rest is computed: the controller works on its answer
        # meanwhile (on the other core)
        if self._refill(run, leading_only=True):
            self._send(run)
            self._answer_due = time.monotonic() + run.request.lockstep_timeout

    def _close_interval(self, run: _Run) -> bool:
        """
        Fix the torque over ``[t_n-1, t_n)`` (closed loop) before sample ``n`` is computed.

        It is fixed when ``n`` is due (paced), once the controller answered ``n - 1``
        (lock-step). False when the wait was cut short (a restart, a stop, or not due yet): the
        loop checks again.
        """
        n = run.next_index
        if n == 0:
            return True
        deadline = run.deadline(run.simulation.stamp_ns(n))
        if deadline is not None:
            delay = deadline - time.monotonic()
            if delay > 0.0:
                if self._wake.wait(min(delay, MAX_WAIT)):
                    self._wake.clear()
                return False
        if run.request.lockstep:
            answer = run.simulation.stamp_ns(n - 1)
            answered = all(
                hold.wait_for(answer, run.request.lockstep_timeout, self._wake.is_set)
                for _, hold in run.holds
            )
            if self._wake.is_set():
                self._wake.clear()
                return False
            if not answered:
                self.missed_steps += 1
        self._seal(run, n - 1)
        return True

    def _seal(self, run: _Run, through: int) -> None:
        for effect, hold in run.holds:
            sealed = hold.seal(through)
            if sealed and self._recorder is not None:
                self._record_commands(effect, hold, sealed)

    def _signal(self) -> None:
        """Wake the loop's thread for a request, whichever wait it is in."""
        self._wake.set()
        with self._turn:
            self._turn.notify_all()

    def _to_bag(self, write: Callable) -> None:
        """``write(recorder)``; if the bag fails, recording stops and publishing goes on."""
        try:
            write(self._recorder)
        except BagError as error:
            self.recording_failure = str(error)
            self._recorder = None
            self._logger.error(f'recording stopped, publishing goes on: {error}')

    def _record(self, stamp: int, columns, index: int) -> None:
        self._to_bag(lambda recorder: recorder.write_sample(stamp, columns, index))

    def _record_sensors(self, stamp_ns: int, record: str) -> None:
        """Record the sensor changes in force from the sample stamped ``stamp_ns``."""
        if self._recorder is not None:
            self._to_bag(
                lambda recorder: recorder.write_message(
                    SENSOR_CHANGES, STRING, stamp_ns, encode_string(record)
                )
            )

    def _record_commands(self, effect, hold, commands) -> None:
        """Record the commands that start holding, at the stamp of the sample they hold from."""

        def write(recorder):
            for command in commands:
                recorder.write_message(
                    effect.topic,
                    effect.message_type,
                    hold.stamp_ns(command.start),
                    encode_command(command, effect),
                )

        self._to_bag(write)

    def _fail(self, reason: str) -> None:
        """Stop publishing until a restart arrives; the node stays up and reports the reason."""
        self.failure = reason
        self._logger.error(f'simulation stopped: {reason}; call ~/reset to restart')
        while not self._take_pending():
            self._wake.wait()
            self._wake.clear()


class StepState(NamedTuple):
    """One consistent look at the sample loop's run (:meth:`Stepping.state`)."""

    simulation: Simulation  # the running run's
    request: RunRequest  # what the running run was started from
    sent: int  # how many of the run's samples have gone out: the index of the next one
    missed_steps: int  # lock-step: how many of them went out without the controller's answer
    failure: str  # why the run stopped publishing ('' while it can publish)
    paused_at: str  # while paused: the sample that goes out on resuming ('' when not paused)
    running: bool  # whether the loop's thread is alive


class Stepping:
    """
    The node's interface for a caller that steps it (``torquefree_ros.testing``): the whole of it.

    :meth:`let_out` and :meth:`hold` work on a stepped node (``TorqueFreeSim(..., stepped=True)``;
    otherwise ``RuntimeError``): a sample goes out only once let out, on top of the rules of
    pacing, pause, reset and lock-step, and sample 0 of every run waits too. :meth:`state` and
    :meth:`topics` work on any node.
    """

    def __init__(self, loop: SampleLoop, resolve: Callable[[str], str]):
        self._loop = loop
        self._resolve = resolve  # a topic's name as the node resolves it

    def let_out(self, count: int = 1) -> None:
        """Let ``count`` (>= 0) more samples go out, one after the other, as each is due."""
        self._loop.let_out(count)

    def hold(self) -> None:
        """Take back every sample let out that has not gone out yet."""
        self._loop.hold()

    def state(self) -> StepState:
        """Return the running run and where it stands, read together."""
        loop = self._loop
        run, last = loop._run, loop.last  # one run: its simulation and request belong together
        sent = last.index + 1 if last is not None and last.simulation is run.simulation else 0
        return StepState(
            simulation=run.simulation,
            request=run.request,
            sent=sent,
            missed_steps=loop.missed_steps,
            failure=loop.failure,
            paused_at=loop.paused_at if loop.paused else '',
            running=loop.running,
        )

    def topics(self, index: int) -> dict[str, bool]:
        """
        Map each topic the running run publishes to whether its sample ``index`` goes out on it.

        Topics by their resolved names: ``angular_velocity``, ``attitude`` and ``/clock`` carry
        every sample, an output at a rate of its own every n-th (``k % n == 0``) but those a
        dropout fault removes.
        """
        request, simulation = self._loop.request, self._loop.simulation
        topics = {self._resolve(ANGULAR_VELOCITY[0]): True, self._resolve(ATTITUDE[0]): True}
        if request.clock:
            topics[self._resolve(CLOCK[0])] = True
        for position, output in enumerate(simulation.outputs):
            topics[self._resolve(output.topic)] = simulation.publishes(position, index)
        return topics


def _publish(publishers, columns, index: int) -> None:
    for publisher, column in zip(publishers, columns):
        message = column.messages[index]
        if message is not None:  # None: an output at a rate of its own skips this sample
            publisher.publish(message)


class _Stop(Exception):
    pass
