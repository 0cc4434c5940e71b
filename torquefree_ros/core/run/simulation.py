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
A started simulation on the contract's sample grid, shared by the node and the offline tools.

Sample ``k`` after a (re)start is the state at exactly ``t_k = k / rate``, stamped
``epoch + t_k`` in integer nanoseconds. Samples come in vectorised blocks; for a given propagator a
sample does not depend on how the blocks were cut. The scene's outputs (``imu``, ``pose``, ...)
are computed with the samples, and only when the scene names them; an output with a ``rate`` of
its own goes out on samples ``k = 0, n, 2n, ...`` (``n`` = rate / its rate), its stream seeing only
those, numbered ``j = k / n``.

The run's faults (``core.faults``) act on the outputs' rows after the sensors computed them; a
dropout removes the sample from its output (its position is left out). :meth:`Simulation.retune`
changes the faults and the sensors' noise from a given sample on (the node's run-time parameters,
a replay of them): the samples computed ahead are then :meth:`Simulation.refaulted`. The
actuators' faults act on the inputs the command holds keep instead (``core.faults.actuators``),
from the sample given on: the motion from it on, which is not computed yet.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .accuracy import estimate_accuracy
from ..effects.commands import command_inputs
from ..exact.regime import GyrostatRegime
from ..faults import ActuatorFaults, describe_fault, FaultInjector
from ..propagators import motion_regime, Propagator
from ..timing.grid import check_rate, sample_stamp_ns, stamps_ns

MAX_STAMP_S = 2**31  # builtin_interfaces/Time.sec is an int32


@dataclass(frozen=True)
class SampleBlock:
    first: int  # index k of the first sample
    times: np.ndarray  # (N,) seconds since the (re)start
    stamps_ns: np.ndarray  # (N,) int64, epoch + t_k
    omega_B: np.ndarray  # (N, 3) rad/s, body frame
    q_NB: np.ndarray  # (N, 4) (x, y, z, w), body in inertial
    internal: np.ndarray  # (N, state_size): the effects' own states (a damper's rate)
    outputs: tuple = ()  # one (n, width) float64 array per output, in Simulation.outputs order
    # per output: the block positions its rows belong to (an output with a rate of its own goes out
    # on every n-th sample only, a dropout on none), None when it has a row for every sample
    output_positions: tuple = ()
    # per output: the sensor's own rows before the faults (every sample it goes out on), and its
    # row of the sample before the block (None when not at hand)
    raw_outputs: tuple = ()
    raw_previous: tuple = ()

    def __len__(self) -> int:
        return self.times.shape[0]


@dataclass(frozen=True)
class Invariants:
    kinetic_energy: float  # J, body + effects
    momentum: float  # |H|, kg m^2/s, body + effects
    energy_drift: float  # (T - T0) / T0 since the (re)start; 0 at rest
    momentum_drift: float  # (|H| - |H|0) / |H|0
    conserved: frozenset  # of "energy", "momentum": which drifts are errors rather than physics


class RecentStates:
    """
    A commanded run's latest states: its last block and the ``span`` samples before it.

    A sensor rebuilt while the run goes on (:meth:`Simulation.retune`) with a latency of ``L``
    samples fills its delay line with the measurements of the ``L`` samples before the change;
    their states are the run's own. A commanded propagator cannot give them again: its command
    hold keeps the commands in force, not the history, and asked for past times it would
    integrate them again under today's command (and go on from there).
    """

    def __init__(self, span: int):
        self.span = span  # run samples kept before the latest block's first
        self.first = 0  # the run sample of the rows below
        self.omega = self.q = self.internal = None

    @classmethod
    def for_run(cls, propagator, streams, every) -> 'RecentStates | None':
        """Return the history a commanded run with delayed sensors keeps, or None."""
        if not propagator.dynamics.holds_per_sample:
            return None
        spans = [getattr(s, 'latency', 0) * n for s, n in zip(streams, every)]
        return cls(max(spans)) if any(spans) else None

    def add(self, first: int, omega, q, internal) -> None:
        """Keep samples ``first ..`` and the ``span`` before them (when they are at hand)."""
        if self.omega is not None and self.first <= first <= self.first + len(self.omega):
            keep = max(first - self.span, self.first)
            cut = keep - self.first
            end = first - self.first
            omega = np.concatenate([self.omega[cut:end], omega])
            q = np.concatenate([self.q[cut:end], q])
            internal = np.concatenate([self.internal[cut:end], internal])
            first = keep
        self.first, self.omega, self.q, self.internal = first, omega, q, internal

    def at(self, rate: float, before: int, name: str) -> '_PastStates':
        """Return a view that answers ``states(times)`` for run samples before ``before``."""
        return _PastStates(self, rate, before, name)


@dataclass(frozen=True)
class _PastStates:
    recent: RecentStates
    rate: float
    before: int
    name: str

    def states(self, times):
        k = np.rint(np.asarray(times) * self.rate).astype(np.int64)
        recent = self.recent
        index = k - recent.first
        count = 0 if recent.omega is None else len(recent.omega)
        if k.size and (index.min() < 0 or index.max() >= count or k.max() >= self.before):
            raise ValueError(
                f'{self.name}: the states of samples {int(k.min())} .. {int(k.max())} its delay '
                f'line needs are no longer at hand (samples {recent.first} .. '
                f'{recent.first + count - 1} are): change it at a later sample'
            )
        return recent.omega[index], recent.q[index], recent.internal[index]


class Simulation:
    """
    A started simulation: ``propagator`` sampled at ``rate`` Hz from ``epoch_ns``.

    ``outputs`` are its output effects.
    """

    def __init__(
        self,
        propagator: Propagator,
        rate: float,
        epoch_ns: int = 0,
        rate_name: str = 'rate',
        outputs=(),
        faults=(),
    ):
        self.propagator = propagator
        self.rate = check_rate(rate, rate_name)
        self.epoch_ns = int(epoch_ns)
        if propagator.dynamics.holds_per_sample:  # commands change the torque at sample times only
            propagator.stop_at_samples(self.rate)
        for _, hold in self.command_holds:
            hold.start(self.rate, self.epoch_ns)
        self.outputs = tuple(output.for_run(propagator) for output in outputs)
        self._every = tuple(output.every(self.rate, rate_name) for output in self.outputs)
        self._streams = [
            output.stream(self.rate / every, propagator)
            for output, every in zip(self.outputs, self._every)
        ]
        #: per output: (j, row) of the last sensor row computed, the row before the next block
        self._last_raw: list = [None] * len(self.outputs)
        #: per output: the first sample j of a stream retune replaced (earlier rows: the old's)
        self._retuned_from: dict[int, int] = {}
        #: a commanded run's latest states, for a retuned sensor's delay line (see retune)
        self._recent = RecentStates.for_run(propagator, self._streams, self._every)
        self._injector = FaultInjector(
            faults, self.outputs, self.rate, self._every, self._raw_row
        )
        self._actuator_faults = ActuatorFaults(faults, propagator.effects, self.rate)
        dynamics = propagator.dynamics
        #: (effect, its part of the states, its monitor) of the effects /diagnostics reports on
        self.monitors = tuple(
            (effect, part, monitor)
            for effect, part in zip(dynamics.effects, dynamics.slices)
            for monitor in (effect.monitor(self.rate),)
            if monitor is not None
        )
        omega0, x0 = propagator.omega0_B, propagator.x0
        self.kinetic_energy0 = float(propagator.energy(omega0, x0))
        self.momentum0 = float(np.linalg.norm(propagator.momentum_B(omega0, x0)))
        self.regime = motion_regime(propagator)  # a free gyrostat's own, with its equilibria

    @property
    def body(self):
        return self.propagator.body

    @property
    def command_holds(self) -> tuple:
        """
        Return ``(effect, hold)`` of each effect that takes commands, in scene order.

        ``torque_command``, commanded ``reaction_wheels``.
        """
        return tuple((effect, effect.hold) for effect in command_inputs(self.propagator.effects))

    def stamp_ns(self, k: int) -> int:
        """Return the stamp of sample ``k``, as :meth:`samples` stamps it."""
        return sample_stamp_ns(k, self.rate, self.epoch_ns)

    def samples(self, first: int, count: int, outputs: bool = True) -> SampleBlock:
        """
        Return samples ``first .. first + count - 1``: their states and the outputs' rows.

        ``outputs=False`` leaves the outputs' rows for :meth:`with_outputs`: a closed loop
        publishes the rates its controller answers before it computes the rest.
        """
        times = np.arange(first, first + count) / self.rate
        if count and self.epoch_ns / 1e9 + times[-1] >= MAX_STAMP_S:
            raise ValueError(
                f'sample {first + count - 1}: its stamp would pass 2^31 s, the end of '
                'builtin_interfaces/Time (int32 seconds)'
            )
        omega, q, internal = self.propagator.states(times)
        if not (np.isfinite(omega).all() and np.isfinite(q).all()):
            bad = int(
                np.argmin(np.all(np.isfinite(omega), axis=1) & np.all(np.isfinite(q), axis=1))
            )
            raise ValueError(
                f'the state at t = {times[bad]:g} s is not finite: '
                'this body and initial state leave '
                f"float64's range (propagator {self.propagator.describe()})"
            )
        block = SampleBlock(first, times, stamps_ns(self.epoch_ns, times), omega, q, internal)
        if self._recent is not None:
            self._recent.add(first, omega, q, internal)
        for _, part, monitor in self.monitors:
            monitor.update(times, omega, internal[:, part])
        return self.with_outputs(block) if outputs else block

    def monitor_diagnostics(self) -> tuple[dict, str]:
        """Return the effects' diagnostic values (wheels' speeds, limits) and their warnings."""
        values, warnings = {}, []
        for _, _, monitor in self.monitors:
            more, warning = monitor.diagnostics()
            values.update(more)
            if warning:
                warnings.append(warning)
        return values, '; '.join(warnings)

    def with_outputs(self, block: SampleBlock) -> SampleBlock:
        """Return ``block`` with the rows of the simulation's outputs, faults applied."""
        raw, previous = [], []
        for position, stream in enumerate(self._streams):
            j, picked = self._picked(block, position)
            rows = stream.rows(j, *self._states(block, picked))
            last = self._last_raw[position]
            previous.append(last[1] if last is not None and last[0] == j - 1 else None)
            if rows.shape[0]:
                self._last_raw[position] = (j + rows.shape[0] - 1, rows[-1].copy())
            raw.append(rows)
        return self._faulted(block, tuple(raw), tuple(previous))

    def _picked(self, block: SampleBlock, position: int) -> tuple[int, np.ndarray | None]:
        """Return output ``position``'s first sample ``j`` in ``block`` and its block positions."""
        every = self._every[position]
        if every == 1:
            return block.first, None
        start = -(-block.first // every) * every  # the block's first k with k % every == 0
        return start // every, np.arange(start - block.first, len(block), every)

    @staticmethod
    def _states(block: SampleBlock, picked) -> tuple:
        if picked is None:
            return block.times, block.omega_B, block.q_NB, block.internal
        return (
            block.times[picked],
            block.omega_B[picked],
            block.q_NB[picked],
            block.internal[picked],
        )

    def _faulted(self, block: SampleBlock, raw: tuple, previous: tuple) -> SampleBlock:
        outputs, positions = [], []
        for position, (rows, before) in enumerate(zip(raw, previous)):
            j, picked = self._picked(block, position)
            rows, keep = self._injector.apply(position, j, rows, before)
            if keep is not None:
                picked = (np.arange(len(block)) if picked is None else picked)[keep]
                rows = rows[keep]
            outputs.append(rows)
            positions.append(picked)
        return dataclasses.replace(
            block,
            outputs=tuple(outputs),
            output_positions=tuple(positions),
            raw_outputs=raw,
            raw_previous=previous,
        )

    # -- faults and run-time changes of the sensors ----------------------------------------------
    @property
    def faults(self) -> tuple:
        """Return the faults in force (``core.faults.Fault``), in their list's order."""
        return tuple(
            sorted(
                self._injector.faults + self._actuator_faults.faults,
                key=lambda fault: fault.index,
            )
        )

    def retune(self, from_index: int, faults=None, outputs=None) -> None:
        """
        Change the faults and the sensors from run sample ``from_index`` on.

        ``faults``: the faults in force from then (None: unchanged); ``outputs``: ``{position:
        output effect}``, sensors rebuilt with other noise parameters (``core.faults.retuned``),
        whose rows from then on are the rebuilt sensor's. Samples computed before are not changed;
        those computed ahead of ``from_index`` are made again by :meth:`refaulted`. The actuators'
        faults act on the intervals from ``from_index`` on (not integrated yet); one that names
        what the run has not is refused first (``FieldError``), nothing changed.
        """
        rebuilt = {}
        for position, output in (outputs or {}).items():
            every = self._every[position]
            output = output.for_run(self.propagator)
            stream = output.stream(self.rate / every, self.propagator)
            first = -(-from_index // every)
            if self._recent is not None and getattr(stream, 'latency', 0):
                # its delay line from the states this run had: a commanded propagator asked for
                # past times would integrate them again under the command now in force
                stream.propagator = self._recent.at(self.rate, from_index, output.name)
                try:
                    stream.rows(first, *(np.empty((0,) + shape) for shape in ((), (3,), (4,))),
                                np.empty((0, self.propagator.dynamics.state_size)))
                finally:
                    stream.propagator = self.propagator
            rebuilt[position] = output, stream, first
        if faults is not None:
            self._actuator_faults.replace(faults, from_index)
        for position, (output, stream, first) in rebuilt.items():
            outputs_now = list(self.outputs)
            outputs_now[position] = output
            self.outputs = tuple(outputs_now)
            self._streams[position] = stream
            self._retuned_from[position] = first
            self._last_raw[position] = None
        if faults is not None:
            self._injector.replace(faults, from_index)

    def refaulted(self, block: SampleBlock) -> SampleBlock:
        """
        Return ``block`` (computed before a :meth:`retune`) with its outputs made again.

        The sensors' rows of samples a retune gave new noise to are computed by the rebuilt
        sensor; every row gets the faults now in force (those before the retune's sample keep
        theirs: the faults set then start there).
        """
        raw = []
        for position, rows in enumerate(block.raw_outputs):
            start = self._retuned_from.get(position)
            j, picked = self._picked(block, position)
            if start is not None and start < j + rows.shape[0]:
                rows = rows.copy()
                offset = max(start - j, 0)
                keep = slice(offset, None)
                chosen = np.arange(len(block))[keep] if picked is None else picked[keep]
                stream = self._streams[position]
                rows[keep] = stream.rows(j + offset, *self._states(block, chosen))
                self._last_raw[position] = (j + rows.shape[0] - 1, rows[-1].copy())
            raw.append(rows)
        return self._faulted(block, tuple(raw), block.raw_previous)

    def publishes(self, position: int, k: int) -> bool:
        """Tell whether output ``position`` goes out on run sample ``k`` (its rate, a dropout)."""
        every = self._every[position]
        return k % every == 0 and self._injector.publishes(position, k // every)

    def fault_diagnostics(self, k: int | None) -> dict:
        """
        Return what /diagnostics says of the faults at run sample ``k`` (None: none out yet).

        ``faults_active``: those acting at the last sample out, ``faults``: how many are in force
        (none: nothing is said).
        """
        faults = self.faults
        if not faults:
            return {}
        active = []
        if k is not None:
            for position, output in enumerate(self.outputs):
                active += self._injector.active(position, k // self._every[position])
            active += self._actuator_faults.active(k)
        return {
            'faults': str(len(faults)),
            'faults_active': '; '.join(describe_fault(f) for f in active) or 'none',
        }

    def _raw_row(self, position: int, j: int) -> np.ndarray:
        """Return output ``position``'s sensor row of its sample ``j``, computed alone."""
        k = j * self._every[position]
        times = np.arange(k, k + 1) / self.rate
        omega, q, internal = self.propagator.states(times)
        return self._streams[position].rows(j, times, omega, q, internal)[0]

    def invariants(self, omega_B, internal=None) -> Invariants:
        """
        Return a sample's energy and momentum (body + effects) and their drift since the (re)start.

        Where the scene conserves them, the drift is the propagator's error (the exact one: zero up
        to rounding); a torque or a damper changes them by physics.
        """
        if internal is None:
            if self.propagator.dynamics.state_size:
                raise ValueError(
                    "internal: the scene's effects carry a state of their own; pass it"
                )
            internal = self.propagator.x0
        energy = float(self.propagator.energy(omega_B, internal))
        momentum = float(np.linalg.norm(self.propagator.momentum_B(omega_B, internal)))
        return Invariants(
            energy,
            momentum,
            _relative(energy, self.kinetic_energy0),
            _relative(momentum, self.momentum0),
            self.propagator.conserved,
        )

    def summary(self) -> str:
        """
        Describe the simulation in one line.

        Inertia, initial state, invariants, regime with its period, propagator and the accuracy it
        delivers, rate and the stamp of sample 0.
        """
        body, p = self.body, self.propagator
        inertia = _fmt(body.moments)
        if np.any(body.tensor - np.diag(np.diag(body.tensor))):
            t = body.tensor
            inertia = (
                f'tensor {_fmt([t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2], t[1, 2]])} '
                f'-> principal moments {inertia}'
            )
        exact = p.dynamics.torque_free or isinstance(self.regime, GyrostatRegime)
        regime = 'regime' if exact else 'torque-free regime of the initial state'
        return (
            f'inertia {inertia} kg m^2, w0 {_fmt(p.omega0_B)} rad/s, q0 {_fmt(p.q0_NB)}, '
            f'T {self.kinetic_energy0:.9g} J, |H| {self.momentum0:.9g} kg m^2/s, '
            f'{regime}: '
            f'{self.regime.summary()}; effects {self.describe_effects()}; '
            f'propagator {p.describe()}, accuracy: {self.accuracy}; {self.rate:g} Hz, '
            f'first stamp {self.epoch_ns // 10**9}.{self.epoch_ns % 10**9:09d} s'
        )

    @cached_property
    def accuracy(self) -> str:
        """
        Describe what the propagator's settings deliver from this initial state.

        Measured once, on fresh propagators:
        :func:`~torquefree_ros.core.run.accuracy.estimate_accuracy`.
        """
        try:
            return estimate_accuracy(self.propagator).describe()
        except Exception as error:  # noqa: BLE001 - the estimate informs; it must not stop a run
            return f'not estimated ({error})'

    def describe_effects(self) -> str:
        named = [effect.describe() for effect in (*self.propagator.effects, *self.outputs)]
        return ', '.join(named) if named else 'none (torque-free)'


def _relative(value: float, reference: float) -> float:
    return (value - reference) / reference if reference else value - reference


def _fmt(values) -> str:
    return '[' + ', '.join(f'{float(v):.9g}' for v in values) + ']'
