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
One sensor of many bodies, one sample at a time: each body's row in a few numpy calls per kind.

:func:`batch_sensor` takes one output of N bodies (:mod:`.sensors`' ``imu``, ``star_tracker``,
``magnetometer`` or ``sun_sensor``, each body's with its own parameters and seed) and returns
their rows of samples ``j = 0, 1, 2, ...`` in order, ``(N, width)`` a sample: a plant batch's
lock-step. Each body's row is bit for bit the row its own stream gives for the
sample alone (the node's closed loop, the offline bag, a campaign):

- **the same draws**: each body's generators are the stream's (``PCG64(seed)``, the Gauss-Markov
  bias's ``spawn_key=(1,)``, the turn-on bias's ``spawn_key=(2,)``), drawn ahead
  :data:`AHEAD` samples a call (PCG64's normals are one sequence however many a call draws, as
  ``sensors._Normals`` relies on), so a sample takes a row of an array, not N generator calls;
  bodies with the same seed share one generator's draws (the same numbers);
- **the same operations**: each body's row is computed element by element with the stream's
  operations in the stream's order (numpy's element-wise operations round as Python's floats do),
  the parameters of the bodies as columns; a body without a term (no misalignment, no bias) skips
  it by a mask, never by adding a zero (``-0.0 + 0.0`` is ``+0.0``); the star tracker's noise
  rotation goes through numpy's matmul one body at a time (a stacked matmul calls the same BLAS
  routine per body as the stream's one-row product);
- **the same environment**: bodies on one orbit (equal places) share ``sensors.environment_at``
  of the sample's time, which is a function of the place and the time alone; the magnetometers
  of bodies on several places (a campaign's orbit phases) read each place's
  ``Place.field_values``, as each body's stream does.

The samples come in order from 0 (a new batch starts over): the gyro's bias walk and the delay
lines of a latency carry from sample to sample.
"""

from __future__ import annotations

import numpy as np

from .sensors import (
    _angle_between,
    _generator,
    _turned,
    body_frame,
    environment_at,
)
from ..environment.earth import EQUATORIAL_RADIUS
from ..frames import quaternion

AHEAD = 64  # samples of normals drawn at a time per generator


def batch_sensor(outputs, rate: float):
    """
    Return the rows of ``outputs`` (one output effect per body, of one kind) at ``rate`` Hz.

    None when their kind has no batched path (its streams are then asked body by body). Each
    body's stream gives its parameters, seeds and templates; it is never asked for rows, so it
    needs no propagator (which only fills a delay line for samples out of order).
    """
    names = {output.name for output in outputs}
    batched = _BATCHES.get(names.pop()) if len(names) == 1 else None
    if batched is None:
        return None
    return batched([output.stream(rate, None) for output in outputs])


class _SeededNormals:
    """
    Normals of one generator per body, ``width`` a sample, in draw order, drawn ahead.

    ``generator(seed)`` makes a body's generator; bodies with one seed share its draws.
    """

    def __init__(self, seeds, generator, width: int):
        self.width = width
        self.unique, self.index = np.unique(np.array(seeds, dtype=np.uint64), return_inverse=True)
        self.generators = [generator(int(seed)) for seed in self.unique]
        self.ahead = np.empty((0, self.unique.size, self.width))
        self.taken = 0

    def sample(self) -> np.ndarray:
        """Return the next sample's normals, ``(N, width)``."""
        if self.taken == self.ahead.shape[0]:
            drawn = [g.standard_normal((AHEAD, self.width)) for g in self.generators]
            self.ahead = np.stack(drawn, axis=1)
            self.taken = 0
        self.taken += 1
        return self.ahead[self.taken - 1][self.index]


def _pcg64(seed: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(seed))


def _process(number: int):
    def make(seed: int) -> np.random.Generator:
        return _generator(seed, number)

    return make


class _DelayLine:
    """
    Each body's rows delayed by its latency (samples): ``blank`` rows before the first.

    A ring of the last ``max(L) + 1`` samples' rows; sample ``j`` gives each body its row of
    ``j - L`` (the stream's deque, for every body at once).
    """

    def __init__(self, latencies, blanks: np.ndarray):
        self.latencies = np.array([latency or 0 for latency in latencies], dtype=np.int64)
        self.blanks = blanks
        self.depth = int(self.latencies.max(initial=0)) + 1
        self.bodies = np.arange(self.latencies.size)
        self.ring = np.empty((self.depth,) + blanks.shape)

    def __call__(self, j: int, rows: np.ndarray) -> np.ndarray:
        if self.depth == 1:
            return rows
        self.ring[j % self.depth] = rows
        if self.depth == self.latencies.min() + 1:  # one latency for every body: one slot
            slot = self.blanks if j < self.depth - 1 else self.ring[(j + 1) % self.depth]
            return slot.copy()  # (the ring's slot is written again later)
        delayed = self.ring[(j - self.latencies) % self.depth, self.bodies]
        return np.where((j < self.latencies)[:, None], self.blanks, delayed)


class _AxisErrors:
    """The bodies' ``sensors.AxisErrors`` as columns: ``(I + S + M) x`` and the digitising."""

    def __init__(self, errors):
        self.matrices = np.array([np.eye(3) if e.matrix is None else e.matrix for e in errors])
        self.has_matrix = np.array([e.matrix is not None for e in errors])
        self.has_lsb = np.array([e.lsb is not None for e in errors])
        self.lsb = _column([e.lsb for e in errors], 1.0)
        self.n_max = _column([e.n_max for e in errors], np.inf)  # no saturation: no clipping
        self.clips = np.array([e.lsb is None and e.limit is not None for e in errors])
        self.limit = _column([e.limit for e in errors], np.inf)

    def sense(self, x: np.ndarray) -> np.ndarray:
        """Return each body's ``(I + S + M) x`` (``x`` without them), ``sense_one``'s sums."""
        if not self.has_matrix.any():
            return x
        C = self.matrices
        sensed = C[:, :, 0] * x[:, 0:1] + C[:, :, 1] * x[:, 1:2] + C[:, :, 2] * x[:, 2:3]
        return np.where(self.has_matrix[:, None], sensed, x)

    def digitise(self, y: np.ndarray) -> np.ndarray:
        """Return ``y`` quantized (half to even, clipped to ``n_max`` codes) or clipped."""
        out = y
        if self.has_lsb.any():
            codes = np.rint(y / self.lsb)
            codes = np.minimum(np.maximum(codes, -self.n_max), self.n_max)
            out = np.where(self.has_lsb[:, None], codes * self.lsb, out)
        if self.clips.any():
            clipped = np.minimum(np.maximum(y, -self.limit), self.limit)
            out = np.where(self.clips[:, None], clipped, out)
        return out


def _column(values, missing=np.nan) -> np.ndarray:
    """Return ``values`` as a column, ``missing`` where a value is None."""
    return np.array([missing if v is None else v for v in values], dtype=float)[:, None]


class _Places:
    """The bodies grouped by their place (orbit and start): the environment once per group."""

    def __init__(self, places):
        groups: dict = {}
        for body, place in enumerate(places):
            if place is not None:
                groups.setdefault(place, []).append(body)
        self.groups = [(place, np.array(bodies)) for place, bodies in groups.items()]
        self.count = len(places)
        # the placed bodies group after group, and each group's size (a row per group, repeated)
        self.grouped = np.concatenate([b for _, b in self.groups] or [np.empty(0, dtype=int)])
        self.sizes = np.array([b.size for _, b in self.groups], dtype=int)

    def vectors(self, times: np.ndarray, quantity: str) -> np.ndarray:
        """Return each body's ``quantity`` at ``times`` (one sample), ``(N, 3)``; NaN: no place."""
        if len(self.groups) == 1 and self.groups[0][1].size == self.count:
            value = environment_at(self.groups[0][0], times, quantity)
            return np.broadcast_to(value, (self.count,) + value.shape[1:])
        out = np.full((self.count, 3), np.nan)
        for place, bodies in self.groups:
            out[bodies] = environment_at(place, times, quantity)
        return out

    def fields(self, j: int, times: np.ndarray, model: str, rate: float) -> np.ndarray:
        """
        Return each body's field of ``model`` at sample ``j`` of ``rate`` (``times``), ``(N, 3)``.

        The field a body's own stream reads (``Place.field_values``: the place's samples ahead,
        computed in one compiled call every few samples), so bodies on many orbits cost a lookup
        each, not an evaluation; NaN: no place.
        """
        if len(self.groups) == 1 and self.groups[0][1].size == self.count:
            return self.vectors(times, model)
        t = float(times[0])
        fields = np.array([place.field_values(t, model, j, rate) for place, _ in self.groups])
        out = np.full((self.count, 3), np.nan)
        out[self.grouped] = np.repeat(fields.reshape(-1, 3), self.sizes, axis=0)
        return out

    def scalars(self, times: np.ndarray, quantity: str) -> np.ndarray:
        """Return each body's ``quantity`` (a number a sample: the shadow), ``(N,)``."""
        out = np.full(self.count, np.nan)
        for place, bodies in self.groups:
            out[bodies] = environment_at(place, times, quantity)[0]
        return out


class _ImuBatch:
    """The gyros of N bodies (``sensors._ImuStream._measure_one``'s operations, as columns)."""

    width = 37

    def __init__(self, streams):
        self.normals = _SeededNormals([s.seed for s in streams], _pcg64, 6)
        self.white_sigma = _column([s.white_sigma for s in streams])
        self.walk_sigma = _column([s.walk_sigma for s in streams])
        markov = [s for s in streams if s.markov_sigma > 0.0]
        self.markov_bodies = np.flatnonzero([s.markov_sigma > 0.0 for s in streams])
        if markov:
            self.markov_normals = _SeededNormals([s.seed for s in markov], _process(1), 3)
            self.markov_sigma = _column([s.markov_sigma for s in markov])
            self.markov_phi = _column([s.markov_phi for s in markov])
            self.markov_drive = _column([s.markov_drive for s in markov])
        self.errors = _AxisErrors([s.errors for s in streams])
        self.templates = np.array([s.template for s in streams])
        self.delay = _DelayLine([s.latency for s in streams], np.array([s.blank for s in streams]))
        # the stream's _restart, as arrays of 3: the initial bias with the turn-on draw, beta zero
        bias = np.array([s.initial_bias for s in streams])
        for b, stream in enumerate(streams):
            if stream.turn_on_sigma > 0.0:
                turn_on = _generator(stream.seed, 2).standard_normal(3)
                bias[b] = stream.initial_bias + stream.turn_on_sigma * turn_on
        self.bias = bias
        self.beta = np.zeros((self.markov_bodies.size, 3))

    def rows(self, j: int, times, omega_B, q_NB) -> np.ndarray:
        g = self.normals.sample()
        if j == 0:  # b + 0.0, as the block's zero step adds
            walk = self.bias + 0.0
        else:
            walk = self.bias + self.walk_sigma * g[:, 3:]
        self.bias = walk
        bias = walk
        if self.markov_bodies.size:
            drive = self.markov_sigma if j == 0 else self.markov_drive
            h = self.markov_normals.sample()
            self.beta = self.markov_phi * self.beta + drive * h
            bias = walk.copy()
            bias[self.markov_bodies] = walk[self.markov_bodies] + self.beta
        measured = (self.errors.sense(omega_B) + bias) + self.white_sigma * g[:, :3]
        rows = self.templates.copy()
        rows[:, 13:16] = self.errors.digitise(measured)
        return self.delay(j, rows)


class _StarTrackerBatch:
    """The star trackers of N bodies (``sensors._StarTrackerStream._measure``, as columns)."""

    width = 37

    def __init__(self, streams):
        self.normals = _SeededNormals([s.seed for s in streams], _pcg64, 3)
        # the transposes as the stream's matmul takes them (the same strides, the same routine)
        self.scaled_axes_T = np.swapaxes(np.array([s.scaled_axes for s in streams]), 1, 2)
        self.max_rate = _column([s.max_rate for s in streams], np.inf)[:, 0]
        self.sun_exclusion = _column([s.sun_exclusion for s in streams])[:, 0]
        self.earth_exclusion = _column([s.earth_exclusion for s in streams])[:, 0]
        self.has_sun = np.array([s.sun_exclusion is not None for s in streams])
        self.has_earth = np.array([s.earth_exclusion is not None for s in streams])
        excluding = self.has_sun | self.has_earth
        self.places = _Places([s.place if e else None for s, e in zip(streams, excluding)])
        self.boresights = np.array([s.boresight for s in streams]).T  # (3, N)
        self.templates = np.array([s.template for s in streams])
        self.blanks = np.array([s.blank for s in streams])
        self.delay = _DelayLine([s.latency for s in streams], self.blanks)

    def rows(self, j: int, times, omega_B, q_NB) -> np.ndarray:
        normals = self.normals.sample()
        rows = self.templates.copy()
        noise = np.matmul(normals[:, np.newaxis, :], self.scaled_axes_T)[:, 0, :]
        rows[:, 0:4] = quaternion.multiply(q_NB, quaternion.exp_rotation(noise))
        lost = self._no_solution(times, omega_B, q_NB)
        if lost.any():
            rows[lost] = self.blanks[lost]
        return self.delay(j, rows)

    def _no_solution(self, times, omega_B, q_NB) -> np.ndarray:
        """Return which bodies have no solution: ``_StarTrackerStream._no_solution``'s rules."""
        lost = np.linalg.norm(omega_B, axis=1) > self.max_rate
        if not self.places.groups:
            return lost
        position = self.places.vectors(times, 'position')
        pointing = np.column_stack(quaternion.rotate_values(q_NB.T, self.boresights))
        if self.has_sun.any():
            towards = self.places.vectors(times, 'sun') - position
            inside = _angle_between(pointing, towards) < self.sun_exclusion
            lost |= self.has_sun & inside
        if self.has_earth.any():
            radius = np.sqrt((position * position).sum(axis=1))
            limb = np.arcsin(EQUATORIAL_RADIUS / radius)
            inside = _angle_between(pointing, -position) < self.earth_exclusion + limb
            lost |= self.has_earth & inside
        return lost


class _MagnetometerBatch:
    """The magnetometers of N bodies (``sensors._MagnetometerStream.rows``, as columns)."""

    width = 12

    def __init__(self, streams):
        self.normals = _SeededNormals([s.seed for s in streams], _pcg64, 3)
        models = sorted({s.model for s in streams})
        # bodies grouped by field model, each group by place
        self.models = [
            (
                model,
                np.array([s.model == model for s in streams]),
                _Places([s.place if s.model == model else None for s in streams]),
            )
            for model in models
        ]
        self.noise = _column([s.noise for s in streams])
        self.bias = np.array([s.bias for s in streams])
        self.errors = _AxisErrors([s.errors for s in streams])
        self.templates = np.array([s.template for s in streams])
        self.rate = streams[0].rate

    def rows(self, j: int, times, omega_B, q_NB) -> np.ndarray:
        normals = self.normals.sample()
        if len(self.models) == 1:
            field_N = self.models[0][2].fields(j, times, self.models[0][0], self.rate)
        else:
            field_N = np.full((normals.shape[0], 3), np.nan)
            for model, bodies, places in self.models:
                field_N[bodies] = places.fields(j, times, model, self.rate)[bodies]
        field_B = body_frame(q_NB, field_N)
        measured = (self.errors.sense(field_B) + self.bias) + self.noise * normals
        rows = self.templates.copy()
        rows[:, 0:3] = self.errors.digitise(measured)
        return rows


class _SunSensorBatch:
    """The sun sensors of N bodies (``sensors._SunSensorStream.rows``, as columns)."""

    width = 3

    def __init__(self, streams):
        self.normals = _SeededNormals([s.seed for s in streams], _pcg64, 3)
        self.places = _Places([s.place for s in streams])
        self.boresights = np.array([s.boresight for s in streams])
        self.has_fov = np.array([s.cos_fov is not None for s in streams])
        self.cos_fov = _column([s.cos_fov for s in streams])[:, 0]
        self.threshold = np.array([s.threshold for s in streams])
        self.noise = _column([s.noise for s in streams])
        self.noisy = self.noise[:, 0] > 0.0
        self.has_bias = np.array([s.bias is not None for s in streams])
        self.bias = np.array([np.zeros(3) if s.bias is None else s.bias[0] for s in streams])
        self.unmounted = np.array([s.unmount is not None for s in streams])
        self.unmount = np.array(
            [np.zeros(3) if s.unmount is None else s.unmount[0] for s in streams]
        )
        self.quantized = np.array([s.lsb is not None for s in streams])
        self.lsb = np.array([1.0 if s.lsb is None else s.lsb for s in streams])
        axes = np.array([s.axes for s in streams])  # (N, 3 rows e1, e2, b, 3)
        self.e1, self.e2, self.b = axes[:, 0], axes[:, 1], axes[:, 2]

    def rows(self, j: int, times, omega_B, q_NB) -> np.ndarray:
        normals = self.normals.sample()
        position = self.places.vectors(times, 'position')
        towards = self.places.vectors(times, 'sun') - position
        distance = np.sqrt(towards[:, 0] ** 2 + towards[:, 1] ** 2 + towards[:, 2] ** 2)
        sun_B = body_frame(q_NB, towards / distance[:, None])
        sun_S = _turned_where(self.unmounted, sun_B, self.unmount)
        seen = self.places.scalars(times, 'shadow') < self.threshold
        if self.has_fov.any():
            seen &= ~self.has_fov | (_along(sun_S, self.boresights) >= self.cos_fov)
        measured = _turned_where(self.has_bias, sun_S, self.bias)
        measured = _turned_where(self.noisy, measured, self.noise * normals)
        if self.quantized.any():
            quantized, front = self._quantized(measured)
            measured = np.where(self.quantized[:, None], quantized, measured)
            seen &= ~self.quantized | front
        return np.where(seen[:, None], measured, 0.0)

    def _quantized(self, s: np.ndarray) -> tuple:
        """``_SunSensorStream._quantized`` with each body's axes and LSB."""
        along = _along(s, self.b)
        alpha = np.arctan2(_along(s, self.e1), along)
        beta = np.arctan2(_along(s, self.e2), along)
        x = np.tan(self.lsb * np.rint(alpha / self.lsb))
        y = np.tan(self.lsb * np.rint(beta / self.lsb))
        norm = np.sqrt(x * x + y * y + 1.0)
        x, y, z = x / norm, y / norm, 1.0 / norm
        vectors = np.column_stack(
            [x * self.e1[:, i] + y * self.e2[:, i] + z * self.b[:, i] for i in range(3)]
        )
        return vectors, along > 0.0


def _along(vectors: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """Return each row's ``v . axis`` with its own axis (``sensors._along``'s sums)."""
    return vectors[:, 0] * axes[:, 0] + vectors[:, 1] * axes[:, 1] + vectors[:, 2] * axes[:, 2]


def _turned_where(which: np.ndarray, vectors: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """Return ``vectors`` turned by ``rotations`` (``sensors._turned``) in the rows ``which``."""
    if not which.any():
        return vectors
    if which.all():
        return _turned(vectors, rotations)
    out = vectors.copy()
    out[which] = _turned(vectors[which], rotations[which])
    return out


_BATCHES = {
    'imu': _ImuBatch,
    'star_tracker': _StarTrackerBatch,
    'magnetometer': _MagnetometerBatch,
    'sun_sensor': _SunSensorBatch,
}

__all__ = ['AHEAD', 'batch_sensor']
