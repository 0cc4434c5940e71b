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
A scene's place: its orbit, the UTC instant of its ``t = 0``, and the environment along the orbit.

A scene's ``orbit:`` section (:meth:`Place.from_mapping`) gives Keplerian elements at an
``epoch`` (:data:`.orbit.ELEMENTS`, optionally ``j2: true``) or a two-line element set (``tle:
[line1, line2]``), and optionally ``start``: the UTC instant of the scene's ``t = 0`` (default: the
orbit's epoch). Scene time ``t`` (s since the start) is orbit time ``start - epoch + t``.

**At sample times** the environment is evaluated exactly (:meth:`Place.state`,
:meth:`Place.field_N`, :meth:`Place.sun_N`): the outputs' rows.

**Inside the integrators** (the torques of ``gravity_gradient`` on an orbit and
``residual_dipole``) the environment is held on *windows* ``[j W, (j + 1) W)`` of scene time, ``W``
= :data:`WINDOW` s: on each, the position and the field in the inertial frame are the Chebyshev
interpolants of degree ``NODES - 1`` through their exact values at the :data:`NODES` Chebyshev
points of the window (the first kind; Trefethen, *Approximation Theory and Approximation Practice*,
2013, ch. 3-4: the error, for functions analytic near the window, falls geometrically with the
degree). The window ends are breakpoints of the motion (the integrators begin a new piece there, as
at a torque schedule's switch), so no step straddles two interpolants. Measured against continuous
evaluation (test/test_orbit_effects.py, every window of a 400 km and a 300 km orbit and of an orbit
of eccentricity 0.9 through its 638 km perigee and near its apogee, 41 times a window): the
interpolated position is within 1.5e-15 of the radius (float64's floor: 1e-8 m in LEO) and the
field (IGRF-14 or the dipole) within 9e-8 nT (3e-12 of ``|B|``); with ``W`` = 120 s the field would
be 2e-5 nT off, with 300 s 0.02 nT, with 6 points 1e-4 nT. A trajectory of 20 minutes under gravity
gradient and a residual dipole differs from one with the environment evaluated at every stage by
4e-12 rad/s, the two integrators' own error at ``rtol`` 1e-11. So the held environment adds nothing
an integrator at ``rtol`` 1e-12 could see, while the integrators read numbers, not models: their
kernels need no copy of the environment's code (a numba kernel's cache follows only its own file,
so a model it called in another file could go stale), and an SGP4 orbit, which no kernel could
evaluate, is held the same way.

Windows are computed :data:`GROUP` at a time (one vectorised evaluation of 128 instants) and kept
for a while, so a closed loop stepping one sample at a time does not evaluate the models per step;
every engine asks for whole groups, so a window's numbers do not depend on who asked first.
"""

from __future__ import annotations

import collections
import math
import threading

import numpy as np

from . import earth, environment_kernels, epochs, magnetic, sun
from .earth import GM
from .orbit import ELEMENTS, KeplerOrbit
from .tle import TLEOrbit
from ..checks.schema import check_keys, child, FieldError, shown
from ..numerics import kernels as switch

#: the length of an environment window, s (a breakpoint of the motion every WINDOW s)
WINDOW = 60.0
#: Chebyshev points a window, the interpolant's degree plus one
NODES = 8
#: windows evaluated together
GROUP = 16
#: groups kept (16 minutes each)
KEPT_GROUPS = 8
#: a sensor's samples whose position and field are computed together (``Place.field_values``)
AHEAD = 64
#: what the integrators hold per window: the position (m) and the field of each model (T),
#: inertial frame; the index of each is its slot in the kernels' environment section
QUANTITIES = ('position', 'igrf', 'dipole')
#: the Earth's polar radius (WGS 84), m: the lowest radius :meth:`Place.lowest_radius` takes for
#: a TLE
POLAR_RADIUS = 6356752.314245
#: the field models an effect or output may name
FIELD_MODELS = ('igrf', 'dipole')

#: the keys of a scene's ``orbit:`` section
SECTION_KEYS = (*ELEMENTS, 'tle', 'start')

# Chebyshev points of the first kind on [-1, 1], x_j = cos(pi (j + 1/2) / N), and the matrix
# taking the values there to the coefficients of sum c_k T_k(x): c_k = (2 / N) sum_j f_j cos(pi k
# (j + 1/2) / N), c_0 halved (Press et al., Numerical Recipes, 3rd ed., eq. 5.8.7)
_J = np.arange(NODES) + 0.5
CHEBYSHEV_POINTS = np.cos(np.pi * _J / NODES)
CHEBYSHEV_MATRIX = (2.0 / NODES) * np.cos(np.pi * np.outer(np.arange(NODES), _J) / NODES)
CHEBYSHEV_MATRIX[0] *= 0.5
del _J


def window_of(segment_start: float) -> int:
    """
    Return the window ``j`` holding the smooth piece that begins at ``segment_start`` (s, >= 0).

    ``j W <= segment_start < (j + 1) W``: a piece never straddles a window end (a breakpoint), so
    a stage evaluated exactly at the end still reads its own piece's window.
    """
    j = math.floor(segment_start / WINDOW)
    if (j + 1) * WINDOW <= segment_start:
        j += 1
    elif j * WINDOW > segment_start:
        j -= 1
    return j


def next_window_end(t: float) -> float:
    """Return the first window end ``k W`` after ``t`` (a breakpoint of the motion)."""
    return (window_of(t) + 1) * WINDOW


def clenshaw(coefficients, x: float) -> float:
    """
    Return ``sum_k c_k T_k(x)`` by Clenshaw's recurrence.

    The operations of the kernels' ``_chebyshev`` (``core/compiled/motion_kernels.py``), in the
    same order.
    """
    b1 = 0.0
    b2 = 0.0
    for k in range(len(coefficients) - 1, 0, -1):
        b1, b2 = coefficients[k] + 2.0 * x * b1 - b2, b1
    return coefficients[0] + x * b1 - b2


class Place:
    """
    A scene's orbit and the UTC instant of its ``t = 0``.

    ``orbit``: a :class:`.orbit.KeplerOrbit` or a :class:`.tle.TLEOrbit`; ``start``: UTC seconds
    since J2000.0 (None: the orbit's epoch); ``start_path``: the scene field that sets the start,
    named by the errors about it (an instant outside the field model's years). Compares equal to a
    place of the same orbit and start.
    """

    def __init__(self, orbit, start: float | None = None, start_path: str = 'orbit.epoch'):
        self.orbit = orbit
        self.start = float(orbit.epoch if start is None else start)
        self.start_path = start_path
        #: orbit time at the scene's t = 0, s since the orbit's epoch
        self.offset = self.start - orbit.epoch
        #: GM of the Earth for the gravity-gradient torque, m^3/s^2 (the elements' own)
        self.gm = orbit.gm if isinstance(orbit, KeplerOrbit) else GM
        #: a Keplerian orbit's constants for the compiled kernels (None: a TLE, through sgp4)
        self._row = orbit.kernel_row() if isinstance(orbit, KeplerOrbit) else None
        if isinstance(orbit, KeplerOrbit):
            self._key = ('kepler', orbit.semi_major_axis, orbit.eccentricity, orbit.inclination,
                         orbit.raan, orbit.argument_of_perigee, orbit.mean_anomaly, orbit.epoch,
                         orbit.j2, self.gm, self.start)
        else:
            self._key = ('tle', orbit.line1, orbit.line2, self.start)
        self._groups: collections.OrderedDict = collections.OrderedDict()
        self._lock = threading.Lock()
        #: model -> ({scene time: index}, (AHEAD, 2, 3) positions and fields, the fields as
        #: floats): a sensor's next samples, computed ahead
        self._ahead: dict = {}

    @classmethod
    def from_mapping(cls, mapping, path: str = 'orbit') -> 'Place':
        """
        Build the place of a scene's ``orbit:`` section; a bad field raises ``FieldError``.

        The Keplerian elements of :data:`.orbit.ELEMENTS` (``epoch`` and ``semi_major_axis``
        required) or ``tle: [line1, line2]``, and ``start`` (UTC, ISO 8601) in either case.
        """
        if not isinstance(mapping, dict):
            raise FieldError(
                path, "expected a mapping: Keplerian elements at an 'epoch', or 'tle: [line1, "
                f"line2]', got {shown(mapping)}"
            )
        check_keys(mapping, SECTION_KEYS, path)
        start = None
        start_path = None
        if 'start' in mapping:
            start_path = child(path, 'start')
            start = epochs.utc_seconds(mapping['start'], start_path)
        elements = {key: value for key, value in mapping.items() if key in ELEMENTS}
        if 'tle' in mapping:
            if elements:
                raise FieldError(
                    child(path, next(iter(elements))),
                    "give either 'tle' or the Keplerian elements, not both",
                )
            where = child(path, 'tle')
            lines = mapping['tle']
            if not (isinstance(lines, list) and len(lines) == 2):
                raise FieldError(where, f'expected the two lines of a TLE, got {shown(lines)}')
            orbit = TLEOrbit(lines[0], lines[1], where)
            return cls(orbit, start, start_path or where)
        orbit = KeplerOrbit.from_mapping(elements, path)
        return cls(orbit, start, start_path or child(path, 'epoch'))

    def __getstate__(self) -> dict:
        """Pickle the orbit and the start (campaign workers), not the values kept nor the lock."""
        state = self.__dict__.copy()
        state['_groups'] = collections.OrderedDict()
        state['_ahead'] = {}
        del state['_lock']
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self._lock = threading.Lock()

    def __eq__(self, other) -> bool:
        if not isinstance(other, Place):
            return NotImplemented
        return self._key == other._key

    def __hash__(self) -> int:
        return hash(self._key)

    def __repr__(self) -> str:
        return f'Place({self._key!r})'

    def describe(self) -> str:
        """Say in a few words where the body is: the orbit and the start (UTC)."""
        begins = epochs.utc_datetime(self.start).isoformat()
        if isinstance(self.orbit, TLEOrbit):
            return f'TLE {self.orbit.line1[2:7]} from {begins}'
        o = self.orbit
        return (f'Keplerian a {o.semi_major_axis / 1e3:.1f} km e {o.eccentricity:g} i '
                f'{math.degrees(o.inclination):.2f} deg{" + J2" if o.j2 else ""} from {begins}')

    # -- at sample times: exact ---------------------------------------------------------------
    def instants(self, t) -> np.ndarray:
        """Turn scene times ``t`` into UTC instants, seconds since J2000.0."""
        return self.start + np.asarray(t, dtype=float)

    def state(self, t):
        """
        Return the inertial position (m) and velocity (m/s) at the scene times ``t``.

        A Keplerian orbit with the kernels enabled: instant by instant through
        :func:`.environment_kernels.kepler_states` (about a microsecond an instant, where numpy's
        vectorised solve costs some 100 us a call whatever its size: a sensor's sample in a closed
        loop), which the tests hold to :meth:`.orbit.KeplerOrbit.state` to rounding.
        """
        orbit_t = self.offset + np.asarray(t, dtype=float)
        if self._row is None or not switch.ENABLED:
            return self.orbit.state(orbit_t)
        flat = np.ascontiguousarray(orbit_t.reshape(-1))
        out = np.empty((flat.size, 6))
        environment_kernels.kernel('kepler_states')(flat, self._row, out)
        out = out.reshape(orbit_t.shape + (6,))
        return out[..., :3], out[..., 3:]

    def earth_fixed(self, t) -> np.ndarray:
        """
        Return ``W`` (``r_EF = W r_N``) at the scene times ``t``, shape ``t.shape + (3, 3)``.

        :func:`.earth.earth_fixed_matrix`; with the kernels enabled instant by instant through
        :func:`.environment_kernels.earth_fixed_matrices` (a frame's sample in a closed loop),
        which the tests hold to numpy's to a few ulp.
        """
        seconds = self.instants(t)
        if not switch.ENABLED:
            return earth.earth_fixed_matrix(seconds)
        flat = np.ascontiguousarray(seconds.reshape(-1))
        out = np.empty((flat.size, 3, 3))
        environment_kernels.kernel('earth_fixed_matrices')(flat, out)
        return out.reshape(seconds.shape + (3, 3))

    def field_N(self, t, position_N, model: str = 'igrf') -> np.ndarray:
        """
        Return the magnetic field (T, inertial) of ``model`` at ``position_N`` at the times ``t``.

        An instant outside IGRF-14's 1900-2030 raises ``FieldError`` naming ``orbit``. With the
        kernels enabled, instant by instant through :func:`.environment_kernels.fields_inertial`
        (about 2 us an instant, where numpy's vectorised path costs some 4 ms a call whatever
        its size: a sensor's sample in a closed loop), which the tests hold to numpy's to
        rounding; numpy's otherwise.
        """
        seconds = self.instants(t)
        if not switch.ENABLED:
            evaluate = magnetic.igrf_inertial if model == 'igrf' else magnetic.dipole_inertial
            return evaluate(position_N, seconds, 'orbit')
        magnetic.check_instants(seconds, 'orbit', years=False)
        position = np.asarray(position_N, dtype=float)
        flat_seconds = np.ascontiguousarray(np.broadcast_to(seconds, position.shape[:-1]).ravel())
        points = np.ascontiguousarray(position.reshape(-1, 3))
        out = np.empty(points.shape)
        environment_kernels.kernel('fields_inertial')(
            0 if model == 'igrf' else 1, points, flat_seconds, magnetic.kernel_table(), out
        )
        return out.reshape(position.shape)

    def position_and_field(self, t: float, model: str = 'igrf') -> tuple:
        """
        Return the position (m) and the field of ``model`` (T) at one scene time ``t``, inertial.

        Two read-only ``(1, 3)`` arrays: the floats of :meth:`state` and :meth:`field_N` at
        ``[t]``. A Keplerian orbit with the kernels enabled: compiled
        (:func:`.environment_kernels.environment_one`, the same operations), where the two
        methods' array handling costs several times the models (a sensor's sample in a closed
        loop); the same errors as :meth:`field_N` outside the model's years. The values a sensor's
        samples in order keep (:meth:`field_values`) are read where they hold ``t``.
        """
        kept = self._ahead.get(model)
        if kept is not None:
            index = kept[0].get(t)
            if index is not None:
                return kept[1][index, 0:1], kept[1][index, 1:2]
        seconds = self.start + t
        if self._row is None or not switch.ENABLED:
            times = np.array([t], dtype=float)
            position = self.state(times)[0]
            out = np.concatenate([position, self.field_N(times, position, model)])
        else:
            if not magnetic.FIRST_INSTANT <= seconds <= magnetic.LAST_INSTANT:  # False for NaN
                magnetic.check_instants(seconds, 'orbit', years=False)  # raises, naming why
            out = np.empty((2, 3))
            environment_kernels.kernel('environment_one')(
                0 if model == 'igrf' else 1, self.offset + t, seconds, self._row,
                magnetic.kernel_table(), out
            )
        out.setflags(write=False)  # and so its rows
        return out[0:1], out[1:2]

    def field_values(self, t: float, model: str, sample: int, rate: float) -> list:
        """
        Return the field of ``model`` (T, inertial) at ``t = sample / rate`` as three floats.

        :meth:`position_and_field`'s field, for a sensor's samples in order: the position and
        field of the next :data:`AHEAD` samples are computed with it in one compiled call
        (:func:`.environment_kernels.environments`: each instant by itself, so the same floats)
        and kept, one set a model, at a fraction of a call's cost a sample.
        """
        kept = self._ahead.get(model)
        if kept is not None:
            index = kept[0].get(t)
            if index is not None:
                return kept[2][index]
        if self._compute_ahead(t, model, sample, rate):
            return self._ahead[model][2][0]
        return self.position_and_field(t, model)[1][0].tolist()

    def _compute_ahead(self, t: float, model: str, sample: int, rate: float) -> bool:
        """
        Compute and keep the environment of samples ``sample ..`` at ``rate``; say whether it was.

        Only a Keplerian orbit with the kernels enabled whose :data:`AHEAD` samples are within the
        field model's years, and when ``t`` is the first of them, ``sample / rate``.
        """
        if self._row is None or not switch.ENABLED:
            return False
        times = np.arange(sample, sample + AHEAD) / rate
        instants = self.start + times
        if not (times[0] == t and magnetic.FIRST_INSTANT <= instants[0]
                and instants[-1] <= magnetic.LAST_INSTANT):
            return False
        out = np.empty((AHEAD, 2, 3))
        environment_kernels.kernel('environments')(
            0 if model == 'igrf' else 1, self.offset + times, instants, self._row,
            magnetic.kernel_table(), out
        )
        out.setflags(write=False)
        self._ahead[model] = (
            {s: i for i, s in enumerate(times.tolist())}, out, out[:, 1].tolist()
        )
        return True

    def sun_N(self, t) -> np.ndarray:
        """Return the Sun's geocentric position (m, inertial) at the scene times ``t``."""
        return sun.sun_position(self.instants(t))

    def lowest_radius(self) -> float:
        """
        Return a radius (m) the orbit never goes below.

        A Keplerian orbit's perigee ``a (1 - e)`` (its J2 drift turns the node and the perigee,
        not ``a`` nor ``e``); a TLE's, whose SGP4 radius has no closed-form floor, the Earth's
        polar radius (WGS 84): the surface.
        """
        if isinstance(self.orbit, KeplerOrbit):
            return self.orbit.semi_major_axis * (1.0 - self.orbit.eccentricity)
        return POLAR_RADIUS

    def field_bound(self, model: str = 'igrf') -> float:
        """
        Return a bound (T) on ``|B|`` of ``model`` anywhere on the orbit, in the model's years.

        Degree by degree, with the Schmidt semi-normalised ``g, h`` (nT) and ``rho = a / r``:
        ``|B_n| <= sqrt((n + 1)(2n + 1)) rho^(n + 2) sqrt(sum_m g_nm^2 + h_nm^2)`` (the radial
        part by Cauchy-Schwarz with ``sum_m P_nm^2 = 1``, the horizontal with ``sum_m |grad_S
        Y_nm|^2 = n (n + 1)`` at every point: the addition theorem, the Schmidt functions of a
        degree, cosine and sine terms alike, being an orthogonal basis of one norm), summed over
        the degrees (1 for the dipole), ``r`` :meth:`lowest_radius`
        (``rho^(n + 2)`` falls with ``r``) and the largest ``sum_m`` of the model's epochs (the
        coefficients between two epochs are their linear interpolation: a convex combination).
        """
        table = magnetic.schmidt_table()  # (epochs, g|h, n, m), nT
        strongest = np.sqrt((table * table).sum(axis=(1, 3)).max(axis=0))  # per degree n
        rho = environment_kernels.IGRF_RADIUS / self.lowest_radius()
        degrees = 1 if model == 'dipole' else environment_kernels.IGRF_DEGREE
        bound = sum(
            math.sqrt((n + 1) * (2 * n + 1)) * rho ** (n + 2) * float(strongest[n])
            for n in range(1, degrees + 1)
        )
        return bound * 1e-9

    def check_field(self) -> None:
        """Refuse a start outside IGRF-14's years (``FieldError`` naming :attr:`start_path`)."""
        magnetic.check_instants(self.start, self.start_path)

    # -- inside the integrators: held per window ------------------------------------------------
    def chebyshev(self, j: int, quantity: int) -> np.ndarray:
        """
        Return the Chebyshev coefficients of a quantity on window ``j``, ``(3, NODES)``.

        ``quantity``: an index of :data:`QUANTITIES`.

        ``x = (t - j W) (2 / W) - 1`` maps the window onto ``[-1, 1]``; :func:`clenshaw` sums them.
        A window past the field model's years raises its ``FieldError`` (naming ``orbit``).
        """
        group, index = divmod(j, GROUP)
        with self._lock:
            values = self._groups.get(group)
            if values is None:
                values = self._groups[group] = {}
                if len(self._groups) > KEPT_GROUPS:
                    self._groups.popitem(last=False)
            else:
                self._groups.move_to_end(group)
            if quantity not in values:
                values[quantity] = self._evaluate_group(group, quantity, values)
        coefficients, errors = values[quantity]
        if index in errors:
            raise errors[index]
        return coefficients[index]

    def evaluate(self, quantity: int, segment_start: float, t: float) -> tuple:
        """
        Return the held ``QUANTITIES[quantity]`` at ``t`` on the piece begun at ``segment_start``.

        Three floats (inertial frame): the window's interpolant, as the kernels read it.
        """
        j = window_of(segment_start)
        coefficients = self.chebyshev(j, quantity).tolist()
        x = (t - j * WINDOW) * (2.0 / WINDOW) - 1.0
        return tuple(clenshaw(row, x) for row in coefficients)

    @staticmethod
    def node_times(j0: int, windows: int = 1) -> np.ndarray:
        """Return the Chebyshev points of windows ``j0 ..``, ``(windows, NODES)`` scene times."""
        starts = (j0 + np.arange(windows)) * WINDOW
        return starts[:, None] + (0.5 * WINDOW) * (CHEBYSHEV_POINTS + 1.0)

    def _evaluate_group(self, group: int, quantity: int, values: dict) -> tuple:
        """
        Return a quantity's coefficients on the windows of ``group`` and the windows refused.

        ``((GROUP, 3, NODES), {window index in the group: FieldError})``. The positions at the
        points are kept in ``values`` for the fields of the same group.
        """
        times = self.node_times(group * GROUP, GROUP)
        if 'nodes' not in values:
            values['nodes'] = self.state(times)[0]
        position = values['nodes']
        errors = {}
        if quantity == 0:
            samples = position
        else:
            model = QUANTITIES[quantity]
            try:
                samples = self.field_N(times, position, model)
            except FieldError:
                # the group reaches past the model's years: the windows inside them are kept, the
                # others raise when a piece asks for them
                samples = np.zeros(times.shape + (3,))
                for w in range(GROUP):
                    try:
                        samples[w] = self.field_N(times[w], position[w], model)
                    except FieldError as error:
                        errors[w] = error
        # c[w, axis, k] = sum_j M[k, j] f[w, j, axis]
        return np.einsum('kj,wja->wak', CHEBYSHEV_MATRIX, samples), errors


__all__ = [
    'FIELD_MODELS',
    'GROUP',
    'NODES',
    'POLAR_RADIUS',
    'Place',
    'QUANTITIES',
    'SECTION_KEYS',
    'WINDOW',
    'clenshaw',
    'next_window_end',
    'window_of',
]
