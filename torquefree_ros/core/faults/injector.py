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
A run's faults applied to its outputs' rows, after the sensors computed them.

Each fault acts on the samples ``j`` of its output's own grid (``t_j = j / rate``, the output's
rate) in its window (:mod:`.schedule`). Its draws (``noise``, ``spikes``) are :mod:`.draws`' 8
uniforms a sample: keyed by ``seed``, the output's own ``seed`` (the scene's), and ``index``, the
fault's place in its list, at sample ``j``; so a sample's faulted row depends on nothing else,
however samples are cut into blocks, live, offline or replayed, and a block of samples draws in
one call. Normals come from uniforms 0 to 3 (:func:`.draws.normals`, three used); a spike's
happening is uniform 4 below its ``probability``. A stuck output holds the
row its sensor read at the sample before the window: kept once read, so the blocks after it need
not hold it.

Faults set while a run goes on (:meth:`FaultInjector.replace`) act from a given sample on: a
window that started earlier starts there; a fault equal to the one at its place in the list
before (same kind, output, times and values) goes on as it was.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np

from .draws import normals, uniforms
from .schedule import ACTUATOR_FAULTS, Fault, FAULTED_OUTPUTS, spike_period_samples
from ..effects.sensors import NOT_PROVIDED
from ..frames import quaternion
from ..timing.grid import first_sample_at_or_after


@dataclasses.dataclass(frozen=True)
class _Window:
    fault: Fault
    output: int  # the output's position in the run
    first: int  # its first sample j
    stop: int | None  # the first sample j after it (None: none)

    def overlap(self, first: int, stop: int) -> tuple[int, int]:
        """Return the part of ``[first, stop)`` inside the window (empty: ``a >= b``)."""
        end = stop if self.stop is None else min(stop, self.stop)
        return max(first, self.first), end


class FaultInjector:
    """
    A run's faults on its outputs.

    ``outputs`` are the run's output effects at ``rate`` Hz, ``every`` each one's step (it goes
    out on run samples ``k = 0, n, 2n, ...``), ``raw_row(i, j)`` output ``i``'s unfaulted row of
    its sample ``j`` when a stuck fault needs one no block in hand holds.
    """

    def __init__(
        self, faults, outputs, rate: float, every, raw_row: Callable[[int, int], np.ndarray]
    ):
        self.outputs = tuple(outputs)
        self.every = tuple(every)
        self.rates = tuple(rate / n for n in self.every)
        self._raw_row = raw_row
        self._positions = {output.topic: i for i, output in enumerate(self.outputs)}
        self.seeds = tuple(int(output.values.get('seed') or 0) for output in self.outputs)
        self.windows: tuple[_Window, ...] = ()
        self._held: dict[tuple, np.ndarray] = {}
        self.replace(faults, 0)

    @property
    def faults(self) -> tuple[Fault, ...]:
        return tuple(window.fault for window in self.windows)

    def replace(self, faults, from_sample: int) -> None:
        """
        Put ``faults`` in force from run sample ``from_sample`` on (0: the run's start).

        An output at a rate of its own (every ``n``-th run sample) starts at its first sample at
        or after it.
        """
        before = {window.fault.index: window for window in self.windows}
        windows = []
        for fault in faults:
            if fault.kind in ACTUATOR_FAULTS:  # on the command holds: .actuators
                continue
            kept = before.get(fault.index)
            if kept is not None and kept.fault == fault:
                windows.append(kept)
                continue
            position = self._positions[fault.output]
            rate = self.rates[position]
            first = first_sample_at_or_after(fault.start, rate)
            stop = None if fault.end is None else first_sample_at_or_after(fault.end, rate)
            if from_sample:
                first = max(first, -(-from_sample // self.every[position]))
            if stop is not None and first >= stop:
                continue  # over before it could act
            windows.append(_Window(fault, position, first, stop))
        self.windows = tuple(windows)

    def active(self, position: int, j: int) -> list[Fault]:
        """Return the faults acting on output ``position``'s sample ``j``."""
        return [
            window.fault
            for window in self.windows
            if window.output == position and window.first <= j < (window.stop or math.inf)
        ]

    def publishes(self, position: int, j: int) -> bool:
        """Tell whether output ``position``'s sample ``j`` goes out (no dropout on it)."""
        return not any(fault.kind == 'dropout' for fault in self.active(position, j))

    def apply(
        self, position: int, first: int, rows: np.ndarray, previous: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray | None]:
        """
        Return output ``position``'s rows of samples ``first ..`` faulted, and which go out.

        ``rows`` are the sensor's own rows; ``previous`` its row of sample ``first - 1`` (None when
        not at hand). The second value is None when every row goes out, else a boolean mask.
        """
        stop = first + rows.shape[0]
        windows = [
            w
            for w in self.windows
            if w.output == position and w.overlap(first, stop)[0] < w.overlap(first, stop)[1]
        ]
        if not windows:
            return rows, None
        name = self.outputs[position].name
        columns = FAULTED_OUTPUTS[name]
        out = rows.copy()
        keep = None
        for window in windows:
            fault = window.fault
            a, b = window.overlap(first, stop)
            part = slice(a - first, b - first)
            if fault.kind == 'dropout':
                keep = np.ones(rows.shape[0], bool) if keep is None else keep
                keep[part] = False
            elif fault.kind == 'stuck':
                if fault.value is not None:
                    out[part, columns.measured] = fault.value
                else:
                    held = self._held_row(window, first, rows, previous)
                    out[part, columns.held] = held[columns.held]
            else:
                self._perturb(fault, name, out, a, b, first)
        return out, keep

    def _held_row(self, window: _Window, first: int, rows, previous) -> np.ndarray:
        """Return the sensor's row a stuck window holds: its sample before the window."""
        key = (window.fault, window.first)
        held = self._held.get(key)
        if held is None:
            j = max(window.first - 1, 0)
            if first <= j < first + rows.shape[0]:
                held = rows[j - first].copy()
            elif j == first - 1 and previous is not None:
                held = np.array(previous, dtype=float)
            else:
                held = np.array(self._raw_row(window.output, j), dtype=float)
            self._held[key] = held
        return held

    def _perturb(self, fault: Fault, name: str, out: np.ndarray, a: int, b: int, first: int):
        """Add a bias, a noise or spikes to samples ``a .. b - 1`` that carry a measurement."""
        seed = self.seeds[self._positions[fault.output]]
        samples = np.arange(a, b)
        if fault.kind == 'bias':
            vectors = np.tile(np.asarray(fault.step, dtype=float), (b - a, 1))
        elif fault.kind == 'noise':
            vectors = fault.sigma * normals(uniforms(seed, fault.index, a, b))
        else:
            draws = uniforms(seed, fault.index, a, b)
            if fault.probability is not None:
                hit = draws[:, 4] < fault.probability
            else:
                rate = self.rates[self._positions[fault.output]]
                hit = np.isin(samples, spike_period_samples(fault, rate, a, b))
            samples, vectors = samples[hit], spike_vectors(fault.magnitude, draws[hit])
        if samples.size:
            perturb(name, out, samples - first, vectors)


def spike_vectors(magnitude, draws: np.ndarray) -> np.ndarray:
    """Return spikes of ``magnitude`` (a number, or one a row) along random directions."""
    directions = normals(draws)
    lengths = np.sqrt((directions * directions).sum(axis=1))
    return np.reshape(magnitude, (-1, 1)) * directions / lengths[:, None]


def perturb(name: str, out: np.ndarray, indices: np.ndarray, vectors: np.ndarray) -> None:
    """Add ``vectors`` to the rows ``indices`` of output ``name`` that carry a measurement."""
    columns = FAULTED_OUTPUTS[name]
    measured = _measured(name, out[indices])
    indices, vectors = indices[measured], vectors[measured]
    values = out[indices, columns.measured]
    if columns.quantity == 'vector':
        out[indices, columns.measured] = values + vectors
    elif columns.quantity == 'quaternion':
        out[indices, columns.measured] = quaternion.multiply(
            values, quaternion.exp_rotation(vectors)
        )
    else:  # a unit vector turned
        turn = quaternion.exp_rotation(vectors).T
        out[indices, columns.measured] = np.column_stack(
            quaternion.rotate_values(turn, values.T)
        )


def _measured(name: str, rows: np.ndarray) -> np.ndarray:
    """Tell which of an output's rows carry a measurement."""
    if name == 'imu':  # REP 145: angular_velocity_covariance[0] = -1 is no estimate
        return rows[:, 16] != NOT_PROVIDED
    if name == 'star_tracker':  # orientation_covariance[0] = -1: no solution
        return rows[:, 4] != NOT_PROVIDED
    if name == 'sun_sensor':  # the zero vector: no Sun
        return np.any(rows != 0.0, axis=1)
    return np.ones(rows.shape[0], bool)


__all__ = ['FaultInjector', 'perturb', 'spike_vectors']
