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
A plant's outputs read at its samples: the sensors a controller on the plant sees.

``PlantSensors(plant)`` (or ``plant.sensors()``) reads the scene's outputs (``imu``,
``star_tracker``, ``magnetometer``, ``sun_sensor``, and any other output) at the plant's current
sample ``k``, for every body: :meth:`PlantSensors.read` returns :class:`SensorReadings`, each
output's row by topic (``(width,)`` for one body, ``(N, width)`` for a batch) and whether it goes
out. The rows are bit for bit those the node and ``torquefree_bag`` (``core.run.Simulation``)
compute for the same scene and sample: the same streams' seeds and draws, the same per-sample
rules (latency, the star tracker's and the sun sensor's no-solution rows), the scene's sensor
``faults:`` on the same windows and draws (each body's ``core.faults.FaultInjector``, applied to
every body's row of a sample at once by ``core.faults.batch.FaultBatch``).

**No message** (what the node does not publish) is a row of NaN with ``published`` False: an
output with a ``rate`` of its own goes out on samples ``k = 0, n, 2n, ...`` only (its stream sees
those, numbered ``j = k / n``), and a ``dropout`` fault publishes nothing in its window. A sample
the sensor publishes without a measurement keeps the sensor's own sign of it (REP 145's
``covariance[0] = -1`` of the gyro before its latency and of the star tracker without a solution,
the sun sensor's zero vector).

The four sensors of a batch are computed for every body at once (``core.effects.sensor_batch``);
other outputs body by body through their own streams. The samples are read in order: every
sample from 0 (after each ``step``; a read at the same sample again returns the same readings,
and a read at sample 0 after ``reset()`` starts the sensors over), since the gyro's bias walk, the
latencies' delay lines and a ``stuck`` fault's held row carry from one sample to the next. The
bodies of a batch must have the same outputs (kind, topic and rate, in the same order); their
parameters, seeds and faults are each body's own.

**Retunes** (:meth:`PlantSensors.retune`, the node's ``sensor_noise`` parameter): a sensor rebuilt
with other noise parameters by the node's own call (``core.faults.parse_noise_changes``), whose
rows from the next sample read on are the rebuilt sensor's stream's at that sample, as in the
node's ``Simulation.retune``; a latency's delay line starts with the rebuilt sensor's
measurements of the states the plant had at the samples before (the reader keeps them), where
the node asks its propagator for them.
"""

from __future__ import annotations

import collections
from typing import NamedTuple

import numpy as np

from ..core.effects.sensor_batch import batch_sensor
from ..core.faults import FaultInjector, parse_noise_changes
from ..core.faults.batch import FaultBatch
from ..core.faults.schedule import ACTUATOR_FAULTS
from ..core.propagators import ATOL_PER_RTOL, DEFAULT_ACCURACY


class SensorReadings(NamedTuple):
    """
    The outputs at one sample ``k`` (time ``t`` s of the run), by topic.

    ``rows``: each output's row (``(width,)``, or ``(N, width)`` for a batch), NaN where no
    message goes out; ``published``: whether it goes out (a bool, or ``(N,)`` for a batch).
    """

    k: int
    t: float
    rows: dict
    published: dict


class PlantSensors:
    """
    The outputs of a plant's scenes, read at its samples (see the module's docstring).

    ``plant``: a :class:`~torquefree_ros.plant.Plant` (one body or a batch).
    """

    def __init__(self, plant):
        self.plant = plant
        scenes = plant.scenes
        self.rate = plant.rate
        where = 'scene[0]' if plant.batch else 'scene'
        first = [_signature(output, self.rate, where) for output in scenes[0].outputs]
        for index, scene in enumerate(scenes[1:], start=1):
            signature = [_signature(o, self.rate, f'scene[{index}]') for o in scene.outputs]
            if signature != first:
                raise ValueError(
                    f'scene[{index}]: its outputs ({_describe(signature)}) differ from '
                    f"scene[0]'s ({_describe(first)}): a batch reads the same outputs (kind, "
                    'topic and rate, in order); make one plant per kind'
                )
        #: scene 0's output effects, in order
        self.outputs = tuple(scenes[0].outputs)
        self.topics = tuple(output.topic for output in self.outputs)
        self._every = tuple(every for _, _, every in first)
        #: each body's outputs: its scene's, with the retuned ones rebuilt
        self._outputs_of = [list(scene.outputs) for scene in scenes]
        #: (position, body) -> (the output's first sample j retuned, the rebuilt sensor's stream)
        self._retuned: dict = {}
        # the states of the run samples a retuned sensor's delay line may ask for: a latency's
        # samples before the one read, on the output's grid
        depth = max(
            [
                int(output.values.get('latency_samples') or 0) * every
                for output, every in zip(self.outputs, self._every)
            ],
            default=0,
        )
        self._states = collections.deque(maxlen=depth + 1 if depth else 0)
        self._start()

    def retune(self, topic: str, body: int | None = None, **changes) -> None:
        """
        Change a sensor's noise parameters from the next sample read: the node's ``sensor_noise``.

        ``topic``: the output's topic; ``changes``: its noise parameters in the scene's units
        (``core.faults.NOISE_PARAMETERS``: ``gyro_noise_density``, ``noise``, ...), changes to
        the scene's values (a second retune of an output replaces the first's, as the parameter
        does); ``body``: one body of a batch (None: every body). Checked as the node checks the
        parameter: ``FieldError`` naming the path (``sensor_noise.imu.noise``, ``scene[2].`` before
        it in a batch), and nothing changed. From the next sample read on, the output's rows are
        those of the sensor rebuilt with them (its seed kept: the same normals, scaled); a
        ``reset()`` starts the sensors over with them, as the node's ``~/reset``.
        """
        plant = self.plant
        bodies = range(plant.size) if body is None else [body]
        if body is not None and not (isinstance(body, int) and 0 <= body < plant.size):
            raise ValueError(f'body: expected 0 .. {plant.size - 1}, got {body!r}')
        rebuilt = {}
        for b in bodies:
            path = f'scene[{b}].sensor_noise' if plant.batch else 'sensor_noise'
            scene = plant.scenes[b]
            rebuilt[b] = parse_noise_changes({topic: changes}, path, scene.outputs)[topic]
        position = self.topics.index(topic)
        every = self._every[position]
        first = -(-self._next // every)  # the output's first sample read from now on
        for b, output in rebuilt.items():
            self._outputs_of[b][position] = output
            propagator = self._propagator(b)
            history = _History(self._states, self.rate, b)
            stream = output.for_run(propagator).stream(self.rate / every, history)
            self._retuned[(position, b)] = (first, stream)

    def read(self) -> SensorReadings:
        """
        Return the outputs at the plant's current sample ``k``.

        Refused (``RuntimeError``) when a sample since the last read was not read: the sensors
        read every sample in order from 0.
        """
        plant = self.plant
        k = plant.k
        state = plant.state
        last = self._last
        if last is not None and k == last[0] and _same_state(state, last[1]):
            return last[2]
        if k == 0 and last is not None:
            self._start()
        elif k != self._next:
            raise RuntimeError(
                f'sensors: the plant is at sample {k} and the sensors next read sample '
                f'{self._next}: they read every sample in order from 0 (read after every step, '
                'and after reset(); a run() of several samples skips them)'
            )
        readings = self._read(k, state)
        self._last = (k, state, readings)
        self._next = k + 1
        return readings

    # -- internals -------------------------------------------------------------------------------
    def _start(self) -> None:
        """Build every body's streams and fault injectors: the sensors at their sample 0."""
        plant = self.plant
        scenes = plant.scenes
        self._last = None
        self._next = 0
        self._propagators: dict = {}
        self._retuned = {}  # (the retuned outputs are each body's from sample 0 on)
        self._states.clear()
        self._paths = []  # per output: ('batch', its rows of every body) or ('each', streams)
        for position, every in enumerate(self._every):
            rate = self.rate / every
            effects = [outputs[position] for outputs in self._outputs_of]
            batched = batch_sensor(effects, rate)
            if batched is not None:
                self._paths.append(('batch', batched))
                continue
            each = []
            for body, effect in enumerate(effects):
                propagator = self._propagator(body)
                each.append(effect.for_run(propagator).stream(rate, propagator))
            self._paths.append(('each', each))
        #: per output: each body's sensor row of the last sample read (a stuck fault's row)
        self._previous: list = [None] * len(self.outputs)
        injectors = {}
        for body, scene in enumerate(scenes):
            if any(fault.kind not in ACTUATOR_FAULTS for fault in scene.faults):
                injectors[body] = FaultInjector(
                    scene.faults, scene.outputs, self.rate, self._every, _no_raw_row
                )
        self._faults = FaultBatch(injectors, plant.size) if injectors else None

    def _propagator(self, body: int):
        """Return body ``body``'s propagator as the plant makes it (an output's stream's run)."""
        if body not in self._propagators:
            scene = self.plant.scenes[body]
            accuracy = DEFAULT_ACCURACY if scene.accuracy is None else scene.accuracy
            self._propagators[body] = scene.propagator(
                'dop853', rtol=accuracy, atol=accuracy * ATOL_PER_RTOL
            )
        return self._propagators[body]

    def _read(self, k: int, state) -> SensorReadings:
        plant = self.plant
        count = plant.size
        omega = np.asarray(state.omega_B, dtype=float).reshape(count, 3)
        q = np.asarray(state.q_NB, dtype=float).reshape(count, 4)
        internal = np.asarray(state.internal, dtype=float).reshape(count, -1)
        times = np.array([k / self.rate])
        if self._states.maxlen:
            self._states.append((k, omega, q, internal))
        rows, published = {}, {}
        for position, (topic, every, (kind, path)) in enumerate(
            zip(self.topics, self._every, self._paths)
        ):
            if k % every:
                width = self._width(position)
                out, sent = np.full((count, width), np.nan), np.zeros(count, bool)
            else:
                j = k // every
                if kind == 'batch':
                    raw = path.rows(j, times, omega, q)
                else:
                    raw = np.vstack(
                        [
                            stream.rows(j, times, omega[b: b + 1], q[b: b + 1],
                                        internal[b: b + 1])
                            for b, stream in enumerate(path)
                        ]
                    )
                for (retuned, b), (first, stream) in self._retuned.items():
                    if retuned == position and j >= first:
                        raw[b] = stream.rows(
                            j, times, omega[b: b + 1], q[b: b + 1], internal[b: b + 1]
                        )[0]
                out, sent = self._faulted(position, j, raw)
                self._previous[position] = (j, raw)
            if plant.batch:
                rows[topic], published[topic] = out, sent
            else:
                rows[topic], published[topic] = out[0], bool(sent[0])
        return SensorReadings(k, k / self.rate, rows, published)

    def _faulted(self, position: int, j: int, raw: np.ndarray) -> tuple:
        """Return the rows with each body's faults (``Simulation``'s rule) and which go out."""
        if self._faults is None:
            return raw, np.ones(raw.shape[0], bool)
        previous = self._previous[position]
        before = previous[1] if previous is not None and previous[0] == j - 1 else None
        out, sent = self._faults.apply(position, j, raw, before)
        if not sent.all():  # (a dropout acts: out is the batch's own copy)
            out[~sent] = np.nan
        return out, sent

    def _width(self, position: int) -> int:
        """Return output ``position``'s row width (known once its sample 0 was read)."""
        kind, path = self._paths[position]
        if kind == 'batch':
            return path.width
        previous = self._previous[position]
        return previous[1].shape[1]


def _signature(output, rate: float, where: str) -> tuple:
    try:
        every = output.every(rate)
    except ValueError as error:
        raise ValueError(f'{where}: {error}') from None
    return output.name, output.topic, every


def _describe(signature) -> str:
    named = [f'{name} on {topic} every {every}' for name, topic, every in signature]
    return ', '.join(named) or 'none'


def _same_state(state, other) -> bool:
    return np.array_equal(state.omega_B, other.omega_B) and np.array_equal(
        state.q_NB, other.q_NB
    ) and np.array_equal(state.internal, other.internal)


class _History:
    """
    The plant's states at its past samples, as a retuned sensor's stream asks its propagator.

    A stream fills its latency's delay line with ``states(times)`` of the samples before the
    first it is asked for: here, the states the reader kept (the run's own, not a propagation).
    """

    def __init__(self, kept: collections.deque, rate: float, body: int):
        self.kept, self.rate, self.body = kept, rate, body

    def states(self, times):
        """Return ``(omega_B, q_NB, internal)`` of this body at ``times`` (past samples)."""
        kept = {k: (omega, q, internal) for k, omega, q, internal in self.kept}
        wanted = [round(t * self.rate) for t in np.asarray(times, dtype=float).tolist()]
        missing = [k for k in wanted if k not in kept]
        if missing:
            raise RuntimeError(
                f'sensors: the states of samples {missing[:5]} are not kept (samples are read '
                'in order)'
            )
        b = self.body
        return tuple(np.array([kept[k][part][b] for k in wanted]) for part in range(3))


def _no_raw_row(position: int, j: int):
    """
    Refuse a sensor row that is not at hand; never reached in order.

    A stuck fault holds the row of the sample before its window, which the previous read keeps.
    """
    raise RuntimeError(
        f'sensors: output {position} sample {j}: its row was not read (samples are read in order)'
    )


__all__ = ['PlantSensors', 'SensorReadings']
