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
The sensor faults of many runs, one sample at a time, every run's row at once.

A plant batch's bodies each have their own faults (:class:`.injector.FaultInjector`, their
windows on each output's grid). :class:`FaultBatch` applies all of them to one sample's rows of an
output, ``(N, width)``, in a few numpy calls, bit for bit each body's injector on its row alone:

- every body's windows on the output are columns (kind, first and stop sample, values, the draws'
  Philox key); a sample takes the windows covering it by one comparison;
- a body's faults apply in list order: the windows are taken by their place among the body's
  windows on the output (its rank), and within one rank, where each body has at most one, by kind,
  the same operations as the injector's (:func:`.injector.perturb`) on the rows of those bodies;
- the draws (``noise``, ``spikes``) of every window come at once from :func:`.draws.uniforms_at`
  (the same Philox bits as numpy's, which the injector draws through), :data:`DRAWN_AHEAD`
  samples a call: a sample's draws depend on its index alone, so drawing ahead changes none;
- a ``stuck`` window holds the body's sensor row of the sample before it, read once (the sample's
  own row at sample 0, else the previous sample's), as the injector keeps it.
"""

from __future__ import annotations

import numpy as np

from .draws import fault_key, normals, uniforms_at
from .injector import perturb, spike_vectors
from .schedule import FAULTED_OUTPUTS, spike_period_samples

_KINDS = ('dropout', 'stuck_value', 'stuck', 'bias', 'noise', 'spikes')
_DRAWN = (_KINDS.index('noise'), _KINDS.index('spikes'))
_NEVER = np.iinfo(np.int64).max  # the stop of a window to the run's end
_PERIOD_AHEAD = 256  # samples of a periodic spike fault listed at a time
DRAWN_AHEAD = 32  # samples of draws a window draws at a time


class FaultBatch:
    """
    The sensor faults of bodies ``0 .. count - 1`` on their outputs.

    ``injectors``: body -> its :class:`.injector.FaultInjector` (a body without faults has none);
    the bodies' outputs are the same (kind, topic, rate, in order).
    """

    def __init__(self, injectors: dict, count: int):
        self.count = int(count)
        positions = sorted({w.output for i in injectors.values() for w in i.windows})
        self._outputs = {
            position: _OutputFaults(position, injectors) for position in positions
        }

    def apply(
        self, position: int, j: int, rows: np.ndarray, previous: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """
        Return output ``position``'s rows of sample ``j`` faulted, and which go out.

        ``rows``: every body's sensor row ``(N, width)``; ``previous``: their rows of sample
        ``j - 1`` (None when not at hand). The second value is a boolean ``(N,)``.
        """
        faults = self._outputs.get(position)
        sent = np.ones(self.count, bool)
        if faults is None:
            return rows, sent
        return faults.apply(j, rows, previous, sent)


class _OutputFaults:
    """Every body's windows on one output, as columns."""

    def __init__(self, position: int, injectors: dict):
        windows = [
            (body, rank, window)
            for body, injector in injectors.items()
            for rank, window in enumerate(w for w in injector.windows if w.output == position)
        ]
        injector = next(iter(injectors.values()))
        self.name = injector.outputs[position].name
        self.columns = FAULTED_OUTPUTS[self.name]
        self.rate = injector.rates[position]
        faults = [window.fault for _, _, window in windows]
        self.faults = faults
        self.body = np.array([body for body, _, _ in windows], dtype=np.int64)
        self.rank = np.array([rank for _, rank, _ in windows], dtype=np.int64)
        self.ranks = int(self.rank.max(initial=-1)) + 1
        self.first = np.array([w.first for _, _, w in windows], dtype=np.int64)
        self.stop = np.array(
            [_NEVER if w.stop is None else w.stop for _, _, w in windows], dtype=np.int64
        )
        self.kind = np.array([_kind(fault) for fault in faults], dtype=np.int64)
        self.drawn = np.isin(self.kind, _DRAWN)
        self.keys = np.array(
            [
                fault_key(injectors[body].seeds[position], window.fault.index)
                if drawn else (0, 0)
                for (body, _, window), drawn in zip(windows, self.drawn)
            ],
            dtype=np.uint64,
        ).reshape(-1, 2)
        width = 4 if self.name == 'star_tracker' else 3
        self.value = _rows([f.value or f.step for f in faults], width)
        self.sigma = _numbers([f.sigma for f in faults])
        self.magnitude = _numbers([f.magnitude for f in faults])
        self.probability = _numbers([f.probability for f in faults])
        self.held: np.ndarray | None = None  # each stuck window's held row, once read
        # each drawing window's uniforms of samples ahead_from .. ahead_from + DRAWN_AHEAD - 1, in
        # its row of ahead (the windows that draw, in order)
        self.ahead_row = np.cumsum(self.drawn) - 1
        self.ahead = np.empty((int(self.drawn.sum()), DRAWN_AHEAD, 8))
        self.ahead_from = np.full(len(faults), -DRAWN_AHEAD - 1, dtype=np.int64)
        self.known = np.zeros(len(faults), bool)
        self._periods: dict = {}  # window -> (stop, the spike samples listed before it)

    def apply(self, j: int, rows, previous, sent) -> tuple[np.ndarray, np.ndarray]:
        active = np.flatnonzero((self.first <= j) & (j < self.stop))
        if not active.size:
            return rows, sent
        out = rows.copy()
        drawn = active[self.drawn[active]]
        draws = np.empty((self.kind.size, 8))
        if drawn.size:
            draws[drawn] = self._draws(j, drawn)
        ranks = self.rank[active]
        for rank in range(self.ranks):
            at = active[ranks == rank]
            kinds = self.kind[at]
            for code in np.unique(kinds):
                windows = at[kinds == code]
                self._act(_KINDS[code], j, windows, rows, previous, out, sent, draws)
        return out, sent

    def _draws(self, j: int, windows) -> np.ndarray:
        """Return the uniforms of ``windows`` at sample ``j``, drawing ahead where they end."""
        offset = j - self.ahead_from[windows]
        spent = windows[(offset < 0) | (offset >= DRAWN_AHEAD)]
        if spent.size:
            samples = j + np.arange(DRAWN_AHEAD)
            keys = np.repeat(self.keys[spent], DRAWN_AHEAD, axis=0)
            drawn = uniforms_at(keys, np.tile(samples, spent.size))
            self.ahead[self.ahead_row[spent]] = drawn.reshape(spent.size, DRAWN_AHEAD, 8)
            self.ahead_from[spent] = j
            offset = j - self.ahead_from[windows]
        return self.ahead[self.ahead_row[windows], offset]

    def _act(self, kind, j, windows, rows, previous, out, sent, draws) -> None:
        """Apply the windows of one kind (one a body) to their bodies' rows."""
        bodies = self.body[windows]
        columns = self.columns
        if kind == 'dropout':
            sent[bodies] = False
        elif kind == 'stuck_value':
            out[bodies, columns.measured] = self.value[windows]
        elif kind == 'stuck':
            out[bodies, columns.held] = self._held(j, windows, rows, previous)[:, columns.held]
        elif kind == 'bias':
            perturb(self.name, out, bodies, self.value[windows, :3])
        elif kind == 'noise':
            perturb(self.name, out, bodies, self.sigma[windows, None] * normals(draws[windows]))
        else:
            hit = self._spiking(j, windows, draws)
            windows = windows[hit]
            if windows.size:
                vectors = spike_vectors(self.magnitude[windows], draws[windows])
                perturb(self.name, out, self.body[windows], vectors)

    def _held(self, j: int, windows, rows, previous) -> np.ndarray:
        """Return the rows the stuck ``windows`` hold: their bodies' rows before the window."""
        if self.held is None:
            self.held = np.empty((self.kind.size, rows.shape[1]))
        unread = windows[~self.known[windows]]
        if unread.size:
            before = np.maximum(self.first[unread] - 1, 0)
            now, last = unread[before == j], unread[before == j - 1]
            if now.size + last.size < unread.size or (last.size and previous is None):
                raise RuntimeError(
                    f'faults: {self.name} sample {j}: a stuck fault holds a row not at hand '
                    '(samples are read in order)'
                )
            self.held[now] = rows[self.body[now]]
            if last.size:
                self.held[last] = previous[self.body[last]]
            self.known[unread] = True
        return self.held[windows]

    def _spiking(self, j: int, windows, draws) -> np.ndarray:
        """Tell which spike ``windows`` have a spike at sample ``j``."""
        probability = self.probability[windows]
        hit = draws[windows, 4] < probability
        periodic = np.isnan(probability)
        for place in np.flatnonzero(periodic):
            window = int(windows[place])
            stop, samples = self._periods.get(window, (-1, ()))
            if j >= stop:
                stop = j + _PERIOD_AHEAD
                samples = set(spike_period_samples(self.faults[window], self.rate, j, stop))
                self._periods[window] = (stop, samples)
            hit[place] = j in samples
        return hit


def _kind(fault) -> int:
    if fault.kind == 'stuck' and fault.value is not None:
        return _KINDS.index('stuck_value')
    return _KINDS.index(fault.kind)


def _rows(values, width: int) -> np.ndarray:
    """Return ``values`` (tuples or None) as rows of ``width`` (NaN where none)."""
    out = np.full((len(values), width), np.nan)
    for row, value in enumerate(values):
        if value is not None:
            out[row, : len(value)] = value
    return out


def _numbers(values) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=float)


__all__ = ['FaultBatch']
