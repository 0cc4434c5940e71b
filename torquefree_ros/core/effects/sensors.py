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
Sensor outputs: the ``imu`` gyro and the ``star_tracker``, with their datasheet error models.

On the scene's orbit, the ``magnetometer`` and the ``sun_sensor`` (:class:`Magnetometer`,
:class:`SunSensor` say their models) read the environment at each sample's instant.

The gyro and the magnetometer share their scale factor, misalignment, saturation and
quantization (:class:`AxisErrors`: its parameters, checks and application written once).

**Gyro** (``imu``, ``sensor_msgs/Imu`` with the angular velocity only). Sample ``k`` of the
output (``dt = 1 / rate``, the output's own rate) measures the body rate of sample ``k - L``
(``L = latency_samples``); per axis, with the terms of IEEE Std 952-1997 (Annex C)::

    w_s   = (I + S + M) w_B(t_(k-L))           scale factor S = diag(ppm 1e-6), misalignment M
    b_k   = b_0 + b_rw,k + beta_k               turn-on, rate random walk, bias instability
    y_k   = w_s + b_k + n_k                     n_k white (angle random walk)
    out_k = LSB clip(rint(y_k / LSB), +-n_max)  or clip(y_k, +-w_max) without quantization

* angle random walk ``N`` (``angle_random_walk`` deg/sqrt(h), or ``gyro_noise_density``
  rad/s/sqrt(Hz)): ``n_k = N sqrt(rate) g``, the mean of white rate noise over the sample, so the
  Allan deviation is ``N / sqrt(tau)`` and ``ADEV(1 s) = N``;
* rate random walk ``K`` (``rate_random_walk`` deg/h/sqrt(h), or ``gyro_bias_random_walk``
  rad/s/sqrt(s)): ``b_rw,0 = initial_bias``, ``b_rw,k = b_rw,(k-1) + K sqrt(dt) g``, the Wiener
  process's exact increments (variance ``K^2 dt``); Allan deviation ``K sqrt(tau / 3)``;
* bias instability ``B`` (``bias_instability`` deg/h, IEEE 952's coefficient ``B``: a flicker
  floor's Allan deviation is ``B sqrt(2 ln 2 / pi) = 0.664 B``) as a first-order Gauss-Markov
  process of correlation time ``T`` (``bias_correlation_time``, s), the exact discretisation of
  ``beta' = -beta / T + w``: ``beta_0 = sigma g``,
  ``beta_k = phi beta_(k-1) + sigma sqrt(1 - phi^2) g``, ``phi = exp(-dt / T)``, stationary
  variance ``sigma^2``. A single Gauss-Markov process has no flat floor: its Allan deviation
  rises as ``sqrt(tau)`` below ``T``, peaks at ``0.6174 sigma`` at
  ``tau = 1.8926 T`` (the maximum of IEEE 952's eq. C.16) and falls as ``1 / sqrt(tau)`` above.
  ``sigma = 0.664 B / 0.6174`` puts that peak at the flicker floor's height: the bias wanders with
  the datasheet's stability on the time scale ``T`` (choose ``T`` where the datasheet's Allan
  curve has its floor). Gazebo's IMU noise model (``dynamic_bias_stddev``,
  ``dynamic_bias_correlation_time``) and Basilisk's ``imuSensor`` (bounded Gauss-Markov walk) model
  the same term;
* turn-on bias (``turn_on_bias`` deg/h, 1-sigma): ``b_0 = sigma_on g``, drawn once per run;
* scale factor (``scale_factor`` ppm, per axis) and misalignment (``misalignment``, 3 x 3 arcsec,
  zero diagonal: row i, column j is how much of the body rate about j the sensor's axis i reads),
  the small-angle sensor model ``(I + S + M)`` of Groves, *Principles of GNSS, Inertial, and
  Multisensor Integrated Navigation Systems* (2nd ed., eq. 4.19);
* saturation ``w_max`` (``saturation`` deg/s) clips each axis; quantization (``quantization``, one
  LSB in deg/s) rounds to the nearest code (half to even), the codes ``n LSB`` with
  ``|n| <= n_max = floor(w_max / LSB)`` under saturation;
* latency (``latency_samples``, in samples of the output's own rate, a whole number: exact on the
  sample grid): sample ``k`` carries the measurement of sample ``k - L``; the first ``L`` samples
  carry none (zero angular velocity, ``angular_velocity_covariance[0] = -1``, REP 145's "no
  estimate").

``angular_velocity_covariance`` is ``diag(N^2 rate + LSB^2 / 12)`` (rad^2/s^2): the per-sample
variance of the white noise and of the quantization's rounding error (uniform over one LSB); the
biases are not per-sample noise and are left to the consumer's estimator (REP 145). All zero (no
noise) is REP 145's "unknown". Orientation and linear acceleration are "not provided" (``-1``).

**Star tracker** (``star_tracker``, ``sensor_msgs/Imu`` with the orientation only): ``q_meas =
q_NB ⊗ exp(n / 2)``, ``n = sigma_cross (g1 e1 + g2 e2) + sigma_about g3 b`` (``b`` the boresight,
``e1, e2`` across it), ``orientation_covariance = E[n n^T]`` (rad^2, body axes). It has no solution
while the body's rate exceeds ``max_rate`` (deg/s): ``|w| > max_rate``, and, on the scene's orbit,
while the Sun's centre is within ``sun_exclusion`` (deg, a half-angle) of the boresight or the
Earth's limb within ``earth_exclusion`` of it, each at the sample it images (after
``latency_samples``, as the gyro's). A sample without a solution carries
``orientation_covariance[0] = -1`` (REP 145: no estimate; robot_localization's filter then ignores
the orientation, ``ros_filter.cpp``'s IMU callback) and a zero quaternion (never a valid attitude,
so a consumer that ignores the flag fails loudly rather than using a stale one); it is still
published, on the output's grid, so the stamps stay regular.

**Draws.** Every draw comes from the output's ``seed`` and is consumed in sample order, so a
sample's values are the same however the samples are cut into blocks, live, offline, in the plant
or a campaign (a skip forward draws the skipped samples' noise, a skip back starts over). The
white noise and the rate random walk draw 6 normals a sample from ``PCG64(seed)`` (as before the
datasheet terms: old scenes give the same numbers), the Gauss-Markov bias 3 a sample from
``PCG64(SeedSequence(seed, spawn_key=(1,)))``, the turn-on bias 3 once from ``spawn_key=(2,)``;
the star tracker 3 a sample from ``PCG64(seed)``. :mod:`.sensor_batch` computes one sample of many
bodies' sensors at once (a plant batch's lock-step) with these draws and the one-sample path's
operations, bit for bit.
"""

from __future__ import annotations

import abc
import collections
import copy
import math
import threading

import numpy as np

from .base import OutputEffect, OutputStream, register
from ..checks.schema import (
    child,
    choice,
    FieldError,
    integer,
    listing,
    number,
    Param,
    topic_name,
    vector,
)
from ..environment import sun
from ..environment.earth import EQUATORIAL_RADIUS
from ..environment.place import FIELD_MODELS
from ..frames import quaternion

# sensor_msgs/Imu after its header: orientation [0:4], its covariance [4:13], angular_velocity
# [13:16], its covariance [16:25], linear_acceleration [25:28], its covariance [28:37]
IMU_ROW = 37
NOT_PROVIDED = -1.0  # REP 145: element 0 of a covariance is -1 when the quantity is not provided

DEG = math.pi / 180.0
HOUR = 3600.0
ARCSEC = DEG / 3600.0
#: a datasheet unit -> its value in SI (rad, s): the one place the conversions are written
SI = {
    'deg/sqrt(h)': DEG / math.sqrt(HOUR),  # angle random walk -> rad/s/sqrt(Hz) = rad/sqrt(s)
    'deg/h/sqrt(h)': DEG / HOUR / math.sqrt(HOUR),  # rate random walk -> rad/s/sqrt(s)
    'deg/h': DEG / HOUR,  # biases -> rad/s
    'deg/s': DEG,  # saturation, quantization -> rad/s
    'ppm': 1e-6,
    'arcsec': ARCSEC,  # -> rad
    'deg': DEG,  # the sun sensor's angles -> rad
    'T': 1.0,  # the magnetometer's range and LSB: SI already
}
#: a flicker floor's Allan deviation per unit of IEEE 952's bias instability coefficient B
FLICKER_FLOOR = math.sqrt(2.0 * math.log(2.0) / math.pi)  # 0.6643
#: a first-order Gauss-Markov process's Allan deviation at its peak, per unit of its standard
#: deviation, and where the peak is, per unit of its correlation time: the maximum over
#: x = tau / T of (2 / x) (1 - (3 - 4 exp(-x) + exp(-2 x)) / (2 x)) (IEEE 952, eq. C.16)
GM_PEAK = 0.6173642831
GM_PEAK_TAU = 1.8926178601
#: the star tracker's exclusion angles: no solution while the Sun or the Earth is inside
EXCLUSIONS = ('sun_exclusion', 'earth_exclusion')
MAX_LATENCY = 100_000  # samples: the delay line holds as many rows (37 float64 each)
SKIP_CHUNK = 65_536  # samples drawn at a time when skipping forward (bounded memory)


def _matrix3(unit: str):
    """Build a checker of a 3 x 3 matrix written as 3 rows of 3 numbers."""
    rows = listing(vector(3, unit=unit))

    def check(value, path):
        checked = rows(value, path)
        if len(checked) != 3:
            raise FieldError(path, f'expected 3 rows of 3 numbers ({unit}), got {len(checked)}')
        return np.array(checked)

    return check


def _latency():
    return Param(
        integer(0, MAX_LATENCY),
        None,
        "samples of the output's own rate between a measurement and its message",
    )


def _unit_boresight(values, path) -> np.ndarray:
    """Return the ``boresight`` parameter as a unit vector; refuse the zero vector by its path."""
    length = float(np.linalg.norm(values['boresight']))
    if not length > 0.0:
        raise FieldError(child(path, 'boresight'), 'must not be the zero vector')
    return values['boresight'] / length


def boresight_axes(boresight: np.ndarray) -> np.ndarray:
    """
    Return the columns ``e1, e2, b`` of a right-handed body-frame basis about a unit boresight.

    ``e1`` is across ``b`` and the body axis least aligned with it, ``e2 = b x e1``.
    """
    b = boresight
    helper = np.eye(3)[int(np.argmin(np.abs(b)))]  # the body axis least aligned with b
    e1 = np.cross(b, helper)
    e1 /= np.linalg.norm(e1)
    return np.column_stack([e1, np.cross(b, e1), b])


# -- a three-axis sensor's gain and digitisation errors (the gyro's and the magnetometer's) -------


def axis_error_parameters(unit: str, smallest_lsb: float) -> dict:
    """
    Return the parameters of :class:`AxisErrors` for a reading in ``unit`` (a key of :data:`SI`).

    ``smallest_lsb`` keeps every reading the sensor can see a finite number of LSBs.
    """
    return {
        'scale_factor': Param(vector(3, unit='ppm'), None),
        'misalignment': Param(_matrix3('arcsec'), None, 'zero diagonal'),
        'saturation': Param(number(positive=True, unit=unit), None),
        'quantization': Param(number(minimum=smallest_lsb, unit=unit), None, 'one LSB'),
    }


def check_axis_errors(values: dict, path: str, unit: str) -> None:
    """Refuse, with the field path, what :func:`axis_error_parameters`' checks cannot see alone."""
    scale = values['scale_factor']
    if scale is not None and np.any(scale <= -1e6):
        raise FieldError(
            child(path, 'scale_factor'),
            f'every entry must be > -1e6 ppm (an axis reading nothing or reversed), '
            f'got {scale.tolist()}',
        )
    misalignment = values['misalignment']
    if misalignment is not None:
        for i in range(3):
            if misalignment[i, i] != 0.0:
                raise FieldError(
                    child(child(child(path, 'misalignment'), i), i),
                    "the diagonal must be 0: an axis's own gain error is its scale_factor "
                    f'(ppm), got {misalignment[i, i]:g} arcsec',
                )
    lsb, saturation = values['quantization'], values['saturation']
    if lsb is not None and saturation is not None and lsb > saturation:
        raise FieldError(
            child(path, 'quantization'),
            f'one LSB ({lsb:g} {unit}) must not exceed the saturation ({saturation:g} {unit})',
        )


class AxisErrors:
    """
    A three-axis sensor's ``(I + S + M)``, saturation and quantization, in SI.

    From the :func:`axis_error_parameters` of a reading in ``unit``: scale factor ``S = diag(ppm
    1e-6)``, misalignment ``M`` (arcsec, zero diagonal: row i, column j is how much of the input
    along j the sensor's axis i reads), the small-angle sensor model of Groves, *Principles of
    GNSS, Inertial, and Multisensor Integrated Navigation Systems* (2nd ed., eq. 4.19); a reading
    ``y`` (the sensed input, its biases and noise) goes out as ``LSB clip(rint(y / LSB), +-n_max)``
    (half to even, ``n_max = floor(limit / LSB)``) with quantization, else ``clip(y, +-limit)``.

    Two paths give the same floats by the same operations in the same order: blocks (numpy,
    element by element, not BLAS: a row does not depend on the others) and one sample (Python
    floats: a closed loop's lock-step).
    """

    def __init__(self, values: dict, unit: str):
        scale, misalignment = values['scale_factor'], values['misalignment']
        #: ``I + S + M`` (None: the identity, no scale factor nor misalignment)
        self.matrix = None
        if scale is not None or misalignment is not None:
            self.matrix = np.eye(3)
            if scale is not None:
                self.matrix += np.diag(scale * SI['ppm'])
            if misalignment is not None:
                self.matrix += misalignment * SI['arcsec']
        self._matrix_rows = None if self.matrix is None else self.matrix.tolist()
        self.limit, self.lsb, self.n_max = self.codes(
            values['saturation'], values['quantization'], SI[unit]
        )

    @staticmethod
    def codes(saturation, lsb, to_si: float) -> tuple:
        """
        Return ``(limit, LSB, n_max)`` in SI (None where not set) of values in datasheet units.

        ``n_max = floor(saturation / LSB)``, taken as the nearest whole number when within 1e-9
        of it (300 deg/s at 0.01 deg/s is 30 000 codes, though 300 / 0.01 rounds below it).
        """
        limit = None if saturation is None else saturation * to_si
        if lsb is None:
            return limit, None, None
        n_max = None
        if saturation is not None:
            ratio = saturation / lsb
            nearest = round(ratio)
            n_max = float(nearest if abs(ratio - nearest) <= 1e-9 * ratio else math.floor(ratio))
        return limit, lsb * to_si, n_max

    def rounding_variance(self) -> float:
        """Return the quantization's rounding variance ``LSB^2 / 12`` (0 without quantization)."""
        return self.lsb**2 / 12.0 if self.lsb else 0.0

    def sense(self, x: np.ndarray) -> np.ndarray:
        """Return ``(I + S + M) x`` row by row (``x`` itself without them)."""
        if self.matrix is None:
            return x
        # on the transpose: numpy's loops run along the samples, not along 3 columns (2x faster)
        C, columns = self.matrix, x.T
        sensed = C[:, 0:1] * columns[0]
        sensed += C[:, 1:2] * columns[1]
        sensed += C[:, 2:3] * columns[2]
        return sensed.T

    def sense_one(self, x: list) -> list:
        """Return :meth:`sense` of one sample, as Python floats."""
        if self.matrix is None:
            return x
        x0, x1, x2 = x
        return [c0 * x0 + c1 * x1 + c2 * x2 for c0, c1, c2 in self._matrix_rows]

    def digitise(self, measured: np.ndarray) -> np.ndarray:
        """Quantize or clip ``measured`` in place and return it."""
        if self.lsb is not None:
            measured /= self.lsb
            np.rint(measured, out=measured)  # half to even, as Python's round
            if self.n_max is not None:
                np.maximum(measured, -self.n_max, out=measured)
                np.minimum(measured, self.n_max, out=measured)
            measured *= self.lsb
        elif self.limit is not None:
            np.maximum(measured, -self.limit, out=measured)
            np.minimum(measured, self.limit, out=measured)
        return measured

    def digitise_one(self, measured: list) -> list:
        """Return :meth:`digitise` of one sample, as Python floats."""
        lsb, n_max, copysign = self.lsb, self.n_max, math.copysign
        if lsb is not None:
            # half to even and the sign of a -0.0 kept, as np.rint
            if n_max is None:
                return [copysign(float(round(y / lsb)), y) * lsb for y in measured]
            return [
                min(max(copysign(float(round(y / lsb)), y), -n_max), n_max) * lsb
                for y in measured
            ]
        if self.limit is not None:
            return [min(max(y, -self.limit), self.limit) for y in measured]
        return measured


@register
class Imu(OutputEffect):
    name = 'imu'
    summary = (
        'sensor_msgs/Imu gyro on the body, datasheet errors: angle and rate random walk, bias '
        'instability (Gauss-Markov), turn-on bias, scale factor, misalignment, saturation, '
        'quantization, latency; seeded (REP 145 covariances)'
    )
    message_type = 'sensor_msgs/msg/Imu'
    frame = 'body'
    parameters = {
        # the SI white noise and bias walk of the first imu, kept: angle_random_walk and
        # rate_random_walk give the same terms in datasheet units
        'gyro_noise_density': Param(number(minimum=0.0, unit='rad/s/sqrt(Hz)'), 0.0),
        'gyro_bias_random_walk': Param(number(minimum=0.0, unit='rad/s/sqrt(s)'), 0.0),
        'initial_bias': Param(vector(3, unit='rad/s'), np.zeros(3)),
        'angle_random_walk': Param(number(minimum=0.0, unit='deg/sqrt(h)'), None),
        'rate_random_walk': Param(number(minimum=0.0, unit='deg/h/sqrt(h)'), None),
        'bias_instability': Param(
            number(minimum=0.0, unit='deg/h'), None, "IEEE 952's B: the Allan floor is 0.664 B"
        ),
        'bias_correlation_time': Param(
            number(positive=True, unit='s'), None, "the bias instability's Gauss-Markov time"
        ),
        'turn_on_bias': Param(
            number(minimum=0.0, unit='deg/h'), None, '1-sigma, drawn once per run'
        ),
        # an LSB of at least 1e-9 deg/s: any rate a scene allows then stays finite in LSBs
        **axis_error_parameters('deg/s', 1e-9),
        'latency_samples': _latency(),
        'seed': Param(integer(0, 2**63 - 1), 0),
        'topic': Param(topic_name, 'imu'),
        'rate': OutputEffect.RATE,
    }

    @classmethod
    def from_parameters(cls, values, path):
        for new, old, unit in (
            ('angle_random_walk', 'gyro_noise_density', 'rad/s/sqrt(Hz)'),
            ('rate_random_walk', 'gyro_bias_random_walk', 'rad/s/sqrt(s)'),
        ):
            if values[new] is not None and values[old] > 0.0:
                raise FieldError(
                    child(path, new),
                    f'the same term as {old} ({unit}), which the scene gives too: keep one',
                )
        if values['bias_instability'] is not None and values['bias_correlation_time'] is None:
            raise FieldError(
                child(path, 'bias_correlation_time'),
                'missing: bias_instability needs the correlation time (s) of its Gauss-Markov '
                'process',
            )
        if values['bias_instability'] is None and values['bias_correlation_time'] is not None:
            raise FieldError(
                child(path, 'bias_correlation_time'),
                'does nothing without bias_instability (deg/h): give both or neither',
            )
        check_axis_errors(values, path, 'deg/s')
        return cls(**values)

    def noise_density(self) -> float:
        """Angle random walk ``N``, rad/s/sqrt(Hz)."""
        arw = self.values['angle_random_walk']
        return self.values['gyro_noise_density'] if arw is None else arw * SI['deg/sqrt(h)']

    def rate_random_walk(self) -> float:
        """Rate random walk ``K``, rad/s/sqrt(s)."""
        rrw = self.values['rate_random_walk']
        return (
            self.values['gyro_bias_random_walk'] if rrw is None else rrw * SI['deg/h/sqrt(h)']
        )

    def axis_errors(self) -> AxisErrors:
        """Return its scale factor, misalignment, saturation and quantization in SI."""
        return AxisErrors(self.values, 'deg/s')

    def stream(self, rate, propagator):
        return _ImuStream(self, rate, propagator)


class _SensorStream(OutputStream):
    """
    A sensor's rows: seeded draws in sample order and, with a latency, a delay line.

    Subclasses draw the noise of the next samples (:meth:`_noise`) and turn states and noise into
    rows (:meth:`_measure`); ``blank`` is the row of a sample without a measurement.
    """

    def __init__(self, rate: float, propagator, latency: int | None, blank: np.ndarray):
        self.rate = rate
        self.propagator = propagator
        self.latency = latency or 0
        self.blank = blank
        self._restart()
        self.next_out = None  # the output sample the delay line is ready for

    @abc.abstractmethod
    def _restart(self) -> None:
        """Start the draws over: the next sample to draw for is 0 (``next_index``)."""

    @abc.abstractmethod
    def _noise(self, count: int):
        """Draw the noise of the next ``count`` samples (advances ``next_index``)."""

    @abc.abstractmethod
    def _measure(self, times, omega_B, q_NB, lead: int = 0) -> np.ndarray:
        """
        Return the rows of the next samples, whose times and states these are (draws noise).

        After ``lead`` rows of room (the template's), which the caller fills.
        """

    def _seek(self, first: int) -> None:
        """Make sample ``first`` the next to draw for."""
        if first < self.next_index:
            self._restart()
        while first > self.next_index:
            self._noise(min(first - self.next_index, SKIP_CHUNK))

    def rows(self, first, times, omega_B, q_NB, internal):
        count = times.shape[0]
        if not self.latency:
            self._seek(first)
            return self._measure(times, omega_B, q_NB) if count else np.empty((0, IMU_ROW))
        if first != self.next_out:
            self._fill_delay(first)
        self.next_out = first + count
        if not count:
            return np.empty((0, IMU_ROW))
        if count == 1:  # one sample in order (a closed loop's lock-step): rows in, rows out
            self.delayed.append(self._measure(times, omega_B, q_NB)[0])
            return self.delayed.popleft()[np.newaxis]
        # the block measured after room for the line: the line's L rows are copied, not the block
        line = self._measure(times, omega_B, q_NB, lead=self.latency)
        line[: self.latency] = self.delayed
        self.delayed = collections.deque(line[count:])
        return line[:count]

    def _fill_delay(self, first: int) -> None:
        """
        Fill the delay line with the measurements of samples ``first - L .. first - 1``.

        Blank rows before sample 0. Reached only when samples are not asked for in order (the
        node, the bag writer, the plant and campaigns ask in order): the states of those samples
        then come from the propagator at ``j / rate``, the times the simulation asks for at the
        output's own rate.
        """
        start = max(first - self.latency, 0)
        self._seek(start)
        if first > start:
            times = np.arange(start, first) / self.rate
            omega, q, _ = self.propagator.states(times)
            measured = self._measure(times, omega, q)
        else:
            measured = np.empty((0, IMU_ROW))
        blanks = np.tile(self.blank, (self.latency - (first - start), 1))
        #: the rows of samples first - L .. first - 1, oldest first
        self.delayed = collections.deque(np.vstack([blanks, measured]))


class _ImuStream(_SensorStream):

    def __init__(self, imu: Imu, rate: float, propagator):
        values = imu.values
        dt = 1.0 / rate
        self.seed = values['seed']
        self.white_sigma = imu.noise_density() * math.sqrt(rate)
        self.walk_sigma = imu.rate_random_walk() * math.sqrt(dt)
        self.initial_bias = np.asarray(values['initial_bias'], float)
        instability = values['bias_instability'] or 0.0
        self.markov_sigma = FLICKER_FLOOR * instability * SI['deg/h'] / GM_PEAK
        if self.markov_sigma > 0.0:
            ratio = dt / values['bias_correlation_time']
            self.markov_phi = math.exp(-ratio)  # math: an underflow to 0 is no error here
            self.markov_drive = self.markov_sigma * math.sqrt(-math.expm1(-2.0 * ratio))
            from scipy.signal import lfilter  # here, not at the first sample: 0.3 s the first time

            self.lfilter = lfilter
        self.turn_on_sigma = (values['turn_on_bias'] or 0.0) * SI['deg/h']
        self.errors = imu.axis_errors()
        variance = self.white_sigma**2 + self.errors.rounding_variance()
        template = np.zeros(IMU_ROW)
        template[4] = NOT_PROVIDED  # orientation not provided
        template[16:25] = np.diag(np.full(3, variance)).ravel()
        template[28] = NOT_PROVIDED  # linear acceleration not provided
        self.template = template
        blank = template.copy()  # a sample before the first measurement: no estimate
        blank[16:25] = 0.0
        blank[16] = NOT_PROVIDED
        super().__init__(rate, propagator, values['latency_samples'], blank)

    def _restart(self):
        self.rng = _Normals(np.random.Generator(np.random.PCG64(self.seed)), 6)
        self.next_index = 0
        self.bias = self.initial_bias.tolist()  # the walk's b_(k-1) for the next sample
        if self.turn_on_sigma > 0.0:
            turn_on = _generator(self.seed, 2).standard_normal(3)
            self.bias = (self.initial_bias + self.turn_on_sigma * turn_on).tolist()
        if self.markov_sigma > 0.0:
            self.markov_rng = _Normals(_generator(self.seed, 1), 3)
            self.beta = [0.0, 0.0, 0.0]  # beta_(k-1); zero before sample 0

    # Two paths give the same floats by the same operations in the same order: blocks (numpy)
    # and one sample (Python floats, ~3x faster than 1-row arrays: a closed loop's lock-step).

    def _noise(self, count: int):
        """
        Return the white noise and the bias of the next ``count`` samples.

        Sample 0 carries the initial bias (with the turn-on draw) and a stationary Gauss-Markov
        draw.
        """
        normals = self.rng.block(count)
        steps = self.walk_sigma * normals[:, 3:]
        if self.next_index == 0:
            steps[0] = 0.0
        # accumulate is sequential: ((b + s1) + s2) + ..., the same floats however blocks are cut
        bias = np.cumsum(np.vstack([self.bias, steps]), axis=0)[1:]
        self.bias = bias[-1].tolist()
        if self.markov_sigma > 0.0:
            bias += self._markov(count)
        self.next_index += count
        return self.white_sigma * normals[:, :3], bias

    def _markov(self, count: int) -> np.ndarray:
        """
        Return ``beta`` of the next ``count`` samples.

        ``beta_k = phi beta_(k-1) + x_k`` by scipy's lfilter, sequential in its C loop: the floats
        of the plain recursion, its state ``phi beta_(k-1)`` carried from block to block.
        """
        normals = self.markov_rng.block(count)
        drive = self.markov_drive * normals
        if self.next_index == 0:  # beta_0 from the stationary distribution
            drive[0] = self.markov_sigma * normals[0]
        state = self.markov_phi * np.array([self.beta])
        beta, _ = self.lfilter([1.0], [1.0, -self.markov_phi], drive, axis=0, zi=state)
        self.beta = beta[-1].tolist()
        return beta

    def _measure(self, times, omega_B, q_NB, lead=0):
        if omega_B.shape[0] == 1 and not lead:
            return self._measure_one(omega_B[0].tolist())
        white, bias = self._noise(omega_B.shape[0])
        # in place: the same floats, fewer arrays
        measured = np.add(self.errors.sense(omega_B), bias, out=bias)
        measured += white
        rows = np.tile(self.template, (lead + omega_B.shape[0], 1))
        rows[lead:, 13:16] = self.errors.digitise(measured)
        return rows

    def _measure_one(self, w: list) -> np.ndarray:
        """Return the row of the next sample, whose body rates are ``w``: :meth:`_measure`."""
        first = self.next_index == 0
        self.next_index += 1
        g = self.rng.one()
        if first:  # b + 0.0, as the block's zero step adds
            walk = [b + 0.0 for b in self.bias]
        else:
            walk = [b + self.walk_sigma * x for b, x in zip(self.bias, g[3:])]
        self.bias = walk
        bias = walk
        if self.markov_sigma > 0.0:
            drive = self.markov_sigma if first else self.markov_drive
            h = self.markov_rng.one()
            self.beta = [self.markov_phi * b + drive * x for b, x in zip(self.beta, h)]
            bias = [b + beta for b, beta in zip(walk, self.beta)]
        sigma = self.white_sigma
        measured = [(s + b) + sigma * x for s, b, x in zip(self.errors.sense_one(w), bias, g[:3])]
        row = self.template.copy()
        row[13:16] = self.errors.digitise_one(measured)
        return row[np.newaxis]


class _Normals:
    """
    A seeded generator's normals, ``width`` a sample, in draw order.

    One sample at a time (:meth:`one`, a closed loop's lock-step) they are drawn ahead, a chunk
    at a time: PCG64's normals come in one sequence however many a call draws, so drawing ahead
    changes no value, and saves the generator's call per sample.
    """

    AHEAD = 64  # samples drawn at a time for :meth:`one`

    def __init__(self, generator: np.random.Generator, width: int):
        self.generator = generator
        self.width = width
        self.ahead: list = []  # rows drawn and not yet taken, from self.taken on
        self.taken = 0

    def one(self) -> list:
        """Return the next sample's normals as Python floats."""
        if self.taken == len(self.ahead):
            self.ahead = self.generator.standard_normal((self.AHEAD, self.width)).tolist()
            self.taken = 0
        self.taken += 1
        return self.ahead[self.taken - 1]

    def block(self, count: int) -> np.ndarray:
        """Return the normals of the next ``count`` samples, ``(count, width)``."""
        waiting = len(self.ahead) - self.taken
        if not waiting:
            return self.generator.standard_normal((count, self.width))
        used = min(waiting, count)
        rows = np.array(self.ahead[self.taken: self.taken + used]).reshape(used, self.width)
        self.taken += used
        if used == count:
            return rows
        return np.vstack([rows, self.generator.standard_normal((count - used, self.width))])


def _generator(seed: int, process: int) -> np.random.Generator:
    """Return the generator of a sensor's ``process``: ``SeedSequence(seed, spawn_key=(n,))``."""
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence(seed, spawn_key=(process,))))


@register
class StarTracker(OutputEffect):
    name = 'star_tracker'
    summary = (
        'sensor_msgs/Imu with only the orientation: '
        'the attitude turned by a seeded noise rotation, '
        '1-sigma across and about the boresight (arcsec), covariance filled (REP 145); '
        'no solution (orientation_covariance[0] = -1) over max_rate or with the Sun or the '
        'Earth inside its exclusion angles'
    )
    message_type = 'sensor_msgs/msg/Imu'
    frame = 'body'
    parameters = {
        'cross_boresight_noise': Param(number(minimum=0.0, unit='arcsec'), 0.0),
        'about_boresight_noise': Param(number(minimum=0.0, unit='arcsec'), 0.0),
        'boresight': Param(vector(3), np.array([0.0, 0.0, 1.0])),
        'max_rate': Param(
            number(positive=True, unit='deg/s'), None, 'no solution while |w| exceeds it'
        ),
        'sun_exclusion': Param(
            number(positive=True, maximum=180.0, unit='deg'),
            None,
            "half-angle about the boresight: no solution while the Sun's centre is inside it "
            "(needs the scene's orbit)",
        ),
        'earth_exclusion': Param(
            number(positive=True, maximum=180.0, unit='deg'),
            None,
            "half-angle about the boresight: no solution while any of the Earth's disc (its "
            "limb) is inside it (needs the scene's orbit)",
        ),
        'latency_samples': _latency(),
        'seed': Param(integer(0, 2**63 - 1), 0),
        'topic': Param(topic_name, 'star_tracker'),
        'rate': OutputEffect.RATE,
    }

    @classmethod
    def from_parameters(cls, values, path):
        return cls(**{**values, 'boresight': _unit_boresight(values, path)})

    def placed(self, place, path):
        """
        Keep the scene's place when an exclusion angle is set (the Sun's and the Earth's).

        An exclusion angle in a scene without an orbit is refused with its field path.
        """
        given = [key for key in EXCLUSIONS if self.values[key] is not None]
        if not given:
            return self
        if place is None:
            raise FieldError(
                child(path, given[0]),
                "needs the scene's orbit (where the Sun and the Earth are seen from): add an "
                "'orbit:' section (Keplerian elements at an 'epoch', or 'tle: [line1, line2]')",
            )
        placed = copy.copy(self)
        placed.place = place
        return placed

    def noise_axes(self) -> np.ndarray:
        """Return the columns ``e1, e2, b`` of :func:`boresight_axes`: the boresight third."""
        return boresight_axes(self.values['boresight'])

    def noise_sigmas(self) -> np.ndarray:
        """1-sigma (rad) along ``e1, e2, b``."""
        cross, about = self.values['cross_boresight_noise'], self.values['about_boresight_noise']
        return np.array([cross, cross, about]) * ARCSEC

    def covariance(self) -> np.ndarray:
        """``E[n n^T]`` (rad^2) in body axes."""
        axes = self.noise_axes()
        return axes @ np.diag(self.noise_sigmas() ** 2) @ axes.T

    def stream(self, rate, propagator):
        return _StarTrackerStream(self, rate, propagator)


class _StarTrackerStream(_SensorStream):

    def __init__(self, tracker: StarTracker, rate: float, propagator):
        self.seed = tracker.values['seed']
        self.scaled_axes = tracker.noise_axes() * tracker.noise_sigmas()  # n = scaled_axes @ g
        max_rate = tracker.values['max_rate']
        self.max_rate = None if max_rate is None else max_rate * SI['deg/s']
        self.place = tracker.place
        self.boresight = tracker.values['boresight']
        sun_exclusion, earth_exclusion = (
            tracker.values['sun_exclusion'], tracker.values['earth_exclusion']
        )
        self.sun_exclusion = None if sun_exclusion is None else sun_exclusion * SI['deg']
        self.earth_exclusion = None if earth_exclusion is None else earth_exclusion * SI['deg']
        template = np.zeros(IMU_ROW)
        template[4:13] = tracker.covariance().ravel()
        template[16] = NOT_PROVIDED  # angular velocity not provided
        template[28] = NOT_PROVIDED  # linear acceleration not provided
        self.template = template
        blank = template.copy()  # no solution: zero quaternion, orientation not provided
        blank[4:13] = 0.0
        blank[4] = NOT_PROVIDED
        super().__init__(rate, propagator, tracker.values['latency_samples'], blank)

    def _restart(self):
        self.rng = np.random.Generator(np.random.PCG64(self.seed))
        self.next_index = 0

    def _noise(self, count: int):
        self.next_index += count
        return self.rng.standard_normal((count, 3))

    def _no_solution(self, times, omega_B, q_NB) -> np.ndarray | None:
        """
        Return which samples have no solution (None: all have one).

        Over ``max_rate`` the stars smear and the tracker loses its solution; it is blinded while
        the angle between the boresight in the inertial frame, ``R(q_NB) b``, and the direction
        from the body to the Sun's centre is under ``sun_exclusion``, or the angle to the nadir
        is under ``earth_exclusion`` plus the Earth's angular radius ``asin(R / r)`` (its limb
        inside the cone; a sphere of the equatorial radius ``R``: the polar flattening moves the
        limb by up to 0.5 deg at 500 km, inwards). The Sun is excluded whether or not the Earth
        hides it.
        """
        lost = None
        if self.max_rate is not None:
            lost = np.linalg.norm(omega_B, axis=1) > self.max_rate
        if self.sun_exclusion is None and self.earth_exclusion is None:
            return lost
        lost = np.zeros(times.shape[0], bool) if lost is None else lost
        position = environment_at(self.place, times, 'position')
        b = self.boresight.tolist()
        pointing = np.column_stack(
            quaternion.rotate_values(q_NB.T, [np.full(times.shape[0], x) for x in b])
        )
        if self.sun_exclusion is not None:
            towards = environment_at(self.place, times, 'sun') - position
            lost |= _angle_between(pointing, towards) < self.sun_exclusion
        if self.earth_exclusion is not None:
            radius = np.sqrt((position * position).sum(axis=1))
            limb = np.arcsin(EQUATORIAL_RADIUS / radius)
            lost |= _angle_between(pointing, -position) < self.earth_exclusion + limb
        return lost

    def _measure(self, times, omega_B, q_NB, lead=0):
        count = omega_B.shape[0]
        normals = self._noise(count)
        rows = np.tile(self.template, (lead + count, 1))
        measured = rows[lead:]
        measured[:, 0:4] = quaternion.multiply(
            q_NB, quaternion.exp_rotation(normals @ self.scaled_axes.T)
        )
        lost = self._no_solution(times, omega_B, q_NB)
        if lost is not None:
            measured[lost] = self.blank
        return rows


def _angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """
    Return the angle (rad) between the rows of ``a`` and ``b``, row by row.

    ``atan2(|a x b|, a . b)``: accurate at every angle, 0 and pi included (``acos`` is not).
    """
    cross = _cross(a, b)
    return np.arctan2(np.sqrt((cross * cross).sum(axis=1)), (a * b).sum(axis=1))


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``a x b`` row by row: ``np.cross``'s operations, without its axis handling."""
    a0, a1, a2 = a[:, 0], a[:, 1], a[:, 2]
    b0, b1, b2 = b[:, 0], b[:, 1], b[:, 2]
    return np.column_stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


# -- sensors of the environment (the scene's orbit) ----------------------------------------------


class _LastEnvironment(threading.local):
    """The environment at the sample times last asked for, in this thread."""

    def __init__(self):
        self.key = None  # (place, the times' bytes)
        self.values: dict = {}  # quantity -> its values at those times


_LAST_ENVIRONMENT = _LastEnvironment()


def environment_at(place, times: np.ndarray, quantity: str) -> np.ndarray:
    """
    Return ``quantity`` of the environment at the scene times ``times`` in ``place`` (read-only).

    ``position`` (m, inertial), ``sun`` (the Sun's geocentric position, m), ``shadow`` (the hidden
    fraction of its disc) or a field model's name (``igrf``, ``dipole``: the field, T, inertial).
    The values of the last times asked for (in this thread) are kept: the sensors of one body, and
    the bodies of a batch on one orbit (places compare equal by their orbit and start), evaluate
    the environment of a block once. The same floats as evaluating it each time: a function of the
    place and the times alone.
    """
    key = (place, np.asarray(times, dtype=float).tobytes())
    last = _LAST_ENVIRONMENT
    if last.key != key:
        last.key, last.values = key, {}
    values = last.values
    if quantity in values:
        return values[quantity]
    if quantity in FIELD_MODELS and len(times) == 1 and 'position' not in values:
        # a closed loop's sample: the position and the field in one call (read-only)
        values['position'], values[quantity] = place.position_and_field(float(times[0]), quantity)
        return values[quantity]
    if quantity == 'position':
        value = place.state(times)[0]
    elif quantity == 'sun':
        value = place.sun_N(times)
    elif quantity == 'shadow':
        value = sun.shadow_fraction(
            environment_at(place, times, 'position'), environment_at(place, times, 'sun')
        )
    else:
        value = place.field_N(times, environment_at(place, times, 'position'), quantity)
    value.setflags(write=False)
    values[quantity] = value
    return value


def body_frame(q_NB: np.ndarray, vectors_N: np.ndarray) -> np.ndarray:
    """
    Return ``R(q_NB)^T v`` row by row (``(N, 4)``, ``(N, 3)``): inertial vectors in body axes.

    Element by element (``quaternion.rotate_values`` by the conjugate, on columns), so a row does
    not depend on the others: the same floats however the samples are cut into blocks.
    """
    q = np.asarray(q_NB, dtype=float)
    v = np.asarray(vectors_N, dtype=float)
    if q.shape[0] == 1:  # one sample (a closed loop's): floats, the same operations
        turned = quaternion.rotate_values(
            quaternion.conjugate_values(q[0].tolist()), v[0].tolist()
        )
        return np.array([turned])
    return np.column_stack(quaternion.rotate_values(quaternion.conjugate_values(q.T), v.T))


class _SeededRows(OutputStream):
    """
    Rows of a sensor of the environment: three normals a sample from ``PCG64(seed)``, in order.

    A skip forward draws the skipped samples' normals, a skip back starts over (as the gyro's), so
    a sample's noise depends only on its index and the seed. One sample at a time they are drawn
    ahead (:class:`_Normals`: the same values).
    """

    def __init__(self, seed: int):
        self.seed = seed
        self._restart()

    def _restart(self) -> None:
        self.rng = _Normals(np.random.Generator(np.random.PCG64(self.seed)), 3)
        self.next_index = 0

    def _seek(self, first: int) -> None:
        """Make sample ``first`` the next to draw for."""
        if first < self.next_index:
            self._restart()
        while first > self.next_index:
            skipped = min(first - self.next_index, SKIP_CHUNK)
            self.rng.block(skipped)
            self.next_index += skipped

    def normals(self, first: int, count: int) -> np.ndarray:
        """Return the normals ``(count, 3)`` of samples ``first ..``."""
        self._seek(first)
        self.next_index += count
        return self.rng.block(count)

    def normals_one(self, first: int) -> list:
        """Return the normals of sample ``first`` as three Python floats."""
        self._seek(first)
        self.next_index += 1
        return self.rng.one()


#: a magnetometer row: sensor_msgs/MagneticField's magnetic_field [0:3], its covariance [3:12]
MAGNETIC_FIELD_ROW = 12


@register
class Magnetometer(OutputEffect):
    """
    A three-axis magnetometer on the body, ``sensor_msgs/MagneticField`` in tesla, body frame.

    ``B_meas = Q((I + S + M) R(q_NB)^T B_N(r(t_k), t_k) + b + sigma g_k)``: the Earth's field
    (IGRF-14 or the tilted dipole, ``field``) at the orbit's position at the sample's instant,
    exactly, in body axes; the gyro's :class:`AxisErrors` (``scale_factor`` ppm, ``misalignment``
    arcsec with a zero diagonal, ``saturation`` T, ``quantization`` one LSB in T: ``Q``); ``b``
    the constant ``bias`` (T, the sensor's axes); ``g_k`` three normals a sample from
    ``PCG64(seed)``, ``sigma`` the ``noise`` (T, 1-sigma per axis). ``magnetic_field_covariance =
    diag(sigma^2 + LSB^2 / 12)`` (T^2, as the gyro's; all zero without noise nor quantization:
    "unknown", as the message defines it). The field of a sample is evaluated at the sample's
    instant, not held: the torques' held field (``residual_dipole``) agrees with it to 1e-7 nT
    (``environment.place``).
    """

    name = 'magnetometer'
    summary = (
        "sensor_msgs/MagneticField on the scene's orbit: IGRF-14 (or the tilted dipole) in the "
        'body frame, tesla, seeded white noise, a constant bias, scale factor, misalignment, '
        'saturation and quantization'
    )
    message_type = 'sensor_msgs/msg/MagneticField'
    frame = 'body'
    needs_orbit = True
    parameters = {
        'field': Param(choice(*FIELD_MODELS), 'igrf'),
        'noise': Param(number(minimum=0.0, unit='T'), 0.0, '1-sigma white noise per axis'),
        'bias': Param(vector(3, unit='T'), np.zeros(3), "constant, the sensor's axes"),
        # an LSB of at least 1e-15 T: the Earth's field (< 1e-4 T) stays under 1e11 LSBs
        **axis_error_parameters('T', 1e-15),
        'seed': Param(integer(0, 2**63 - 1), 0),
        'topic': Param(topic_name, 'magnetometer'),
        'rate': OutputEffect.RATE,
    }

    @classmethod
    def from_parameters(cls, values, path):
        check_axis_errors(values, path, 'T')
        return cls(**values)

    def placed(self, place, path):
        placed = super().placed(place, path)
        place.check_field()
        return placed

    def stream(self, rate, propagator):
        return _MagnetometerStream(self, rate)


class _MagnetometerStream(_SeededRows):

    def __init__(self, magnetometer: Magnetometer, rate: float):
        values = magnetometer.values
        self.place = magnetometer.place
        self.rate = rate
        self.model = values['field']
        self.noise = values['noise']
        self.bias = np.asarray(values['bias'], dtype=float)
        self.bias_values = self.bias.tolist()
        # no noise and no -0.0 in the bias: (s + b) is never -0.0, so adding the zero noise * g
        # changes no reading, and a sample needs no normals
        self.noiseless = self.noise == 0.0 and all(
            math.copysign(1.0, b) > 0.0 for b in self.bias_values
        )
        self.errors = AxisErrors(values, 'T')
        self.template = np.zeros(MAGNETIC_FIELD_ROW)
        variance = self.noise**2 + self.errors.rounding_variance()
        self.template[3:12] = np.diag(np.full(3, variance)).ravel()
        self.template_row = self.template[np.newaxis]
        super().__init__(values['seed'])

    def rows(self, first, times, omega_B, q_NB, internal):
        count = times.shape[0]
        if count == 1:  # a closed loop's sample
            return self._row_one(first, times, q_NB)
        normals = self.normals(first, count)
        rows = np.tile(self.template, (count, 1))
        if count:
            field_B = body_frame(q_NB, environment_at(self.place, times, self.model))
            measured = (self.errors.sense(field_B) + self.bias) + self.noise * normals
            rows[:, 0:3] = self.errors.digitise(measured)
        return rows

    def _row_one(self, first: int, times: np.ndarray, q_NB: np.ndarray) -> np.ndarray:
        """Return :meth:`rows` of one sample: the same operations on Python floats."""
        # the place's own values (the same floats as environment_at's), kept for the next samples
        field_N = self.place.field_values(float(times[0]), self.model, first, self.rate)
        field_B = quaternion.rotate_values(quaternion.conjugate_values(q_NB.tolist()[0]), field_N)
        sensed = self.errors.sense_one(field_B)
        if self.noiseless:
            measured = [s + bias for s, bias in zip(sensed, self.bias_values)]
        else:
            noise = self.noise
            measured = [
                (s + bias) + noise * x
                for s, bias, x in zip(sensed, self.bias_values, self.normals_one(first))
            ]
        row = self.template_row.copy()
        row[0, 0:3] = self.errors.digitise_one(measured)
        return row


@register
class SunSensor(OutputEffect):
    """
    A sun sensor on the body: the Sun's unit vector in the body frame, ``Vector3Stamped``.

    The direction ``s_B`` from the body (the orbit's position at the sample's instant: the
    parallax of up to 10 arcsec in LEO is in) to the Sun (``environment.sun``, 0.01 deg), in body
    axes; in the sensor's axes ``s_S = exp(-m) s_B``: the sensor frame is the body frame turned by
    the ``misalignment`` rotation vector ``m`` (arcsec), so its field of view turns with it. The
    reading is ``exp(sigma g_k) exp(c) s_S``: a fixed ``bias`` rotation ``c`` (a rotation vector,
    deg), then a seeded small rotation (``noise``, deg, 1-sigma per axis; three normals a sample
    from ``PCG64(seed)``), each applied exactly (Rodrigues' formula). With ``quantization`` (deg,
    one LSB) the sensor reads the two angles of a two-axis digital sun sensor, ``alpha =
    atan2(s . e1, s . b)`` and ``beta = atan2(s . e2, s . b)`` (``e1, e2, b`` of
    :func:`boresight_axes`), rounds each to the nearest code (half to even) and sends the unit
    vector along ``tan(alpha) e1 + tan(beta) e2 + b``: these angles need the front hemisphere, so
    quantization needs a ``field_of_view`` under 90 deg, and a reading that noise or bias turn
    behind it (``s . b <= 0``) is no Sun.

    **No Sun is the zero vector**: the sample still goes out, with ``(0, 0, 0)``, while the Earth
    hides ``shadow_threshold`` or more of the Sun's disc (the penumbra's fraction,
    ``environment.sun.shadow_fraction``; default 0.5) or while the true direction in the sensor's
    axes, ``s_S``, is more than ``field_of_view`` deg (a half-angle) from the ``boresight``
    (default: no limit). A consumer tests the vector's norm: 1 (to rounding) with the Sun, 0
    without.
    """

    name = 'sun_sensor'
    summary = (
        "the Sun's unit vector in the body frame (Vector3Stamped) on the scene's orbit, with "
        'noise, a bias rotation, misalignment and quantized angles; the zero vector while '
        'eclipsed or outside the field of view'
    )
    message_type = 'geometry_msgs/msg/Vector3Stamped'
    frame = 'body'
    needs_orbit = True
    parameters = {
        'boresight': Param(vector(3), np.array([0.0, 0.0, 1.0])),
        'field_of_view': Param(
            number(positive=True, maximum=180.0, unit='deg'),
            None,
            'half-angle about the boresight; default: the whole sky',
        ),
        'shadow_threshold': Param(
            number(positive=True, maximum=1.0),
            0.5,
            "the hidden fraction of the Sun's disc at and above which the sensor sees no Sun",
        ),
        'noise': Param(number(minimum=0.0, unit='deg'), 0.0, '1-sigma per axis, a rotation'),
        'bias': Param(
            vector(3, unit='deg'), None, 'a fixed rotation (rotation vector) of the reading'
        ),
        'misalignment': Param(
            vector(3, unit='arcsec'),
            None,
            "the sensor frame's rotation from the body frame (rotation vector); its field of "
            'view turns with it',
        ),
        'quantization': Param(
            number(positive=True, unit='deg'),
            None,
            'one LSB of the two angles from the boresight; needs a field_of_view under 90 deg',
        ),
        'seed': Param(integer(0, 2**63 - 1), 0),
        'topic': Param(topic_name, 'sun_sensor'),
        'rate': OutputEffect.RATE,
    }

    @classmethod
    def from_parameters(cls, values, path):
        fov = values['field_of_view']
        if values['quantization'] is not None and (fov is None or fov >= 90.0):
            shown = 'none (the whole sky)' if fov is None else f'{fov:g} deg'
            raise FieldError(
                child(path, 'quantization'),
                'the two angles from the boresight need a field_of_view under 90 deg (a '
                f'two-axis sensor sees less than a hemisphere), got {shown}',
            )
        return cls(**{**values, 'boresight': _unit_boresight(values, path)})

    def stream(self, rate, propagator):
        return _SunSensorStream(self)


class _SunSensorStream(_SeededRows):

    def __init__(self, sensor: SunSensor):
        values = sensor.values
        self.place = sensor.place
        self.boresight = values['boresight']
        fov = values['field_of_view']
        self.cos_fov = None if fov is None else math.cos(fov * DEG)
        self.threshold = values['shadow_threshold']
        self.noise = values['noise'] * SI['deg']
        bias, misalignment = values['bias'], values['misalignment']
        self.bias = None if bias is None else (bias * SI['deg'])[np.newaxis]
        self.unmount = None if misalignment is None else (-misalignment * SI['arcsec'])[np.newaxis]
        lsb = values['quantization']
        self.lsb = None if lsb is None else lsb * SI['deg']
        self.axes = boresight_axes(self.boresight).T.tolist()  # rows e1, e2, b
        super().__init__(values['seed'])

    def rows(self, first, times, omega_B, q_NB, internal):
        count = times.shape[0]
        normals = self.normals(first, count)
        if not count:
            return np.zeros((0, 3))
        position = environment_at(self.place, times, 'position')
        sun_N = environment_at(self.place, times, 'sun')
        towards = sun_N - position
        distance = np.sqrt(towards[:, 0] ** 2 + towards[:, 1] ** 2 + towards[:, 2] ** 2)
        sun_B = body_frame(q_NB, towards / distance[:, None])
        sun_S = sun_B if self.unmount is None else _turned(sun_B, self.unmount)
        seen = environment_at(self.place, times, 'shadow') < self.threshold
        if self.cos_fov is not None:
            seen &= _along(sun_S, self.boresight.tolist()) >= self.cos_fov
        measured = sun_S if self.bias is None else _turned(sun_S, self.bias)
        if self.noise > 0.0:
            measured = _turned(measured, self.noise * normals)
        if self.lsb is not None:
            measured, front = self._quantized(measured)
            seen &= front
        return np.where(seen[:, None], measured, 0.0)

    def _quantized(self, s: np.ndarray) -> tuple:
        """
        Return the unit vectors of the quantized angles of ``s``, and where ``s . b > 0``.

        ``alpha = atan2(s . e1, s . b)``, ``beta`` with ``e2``, each rounded to whole LSBs.
        """
        e1, e2, b = self.axes
        along = _along(s, b)
        alpha = np.arctan2(_along(s, e1), along)
        beta = np.arctan2(_along(s, e2), along)
        x = np.tan(self.lsb * np.rint(alpha / self.lsb))
        y = np.tan(self.lsb * np.rint(beta / self.lsb))
        norm = np.sqrt(x * x + y * y + 1.0)
        x, y, z = x / norm, y / norm, 1.0 / norm
        vectors = np.column_stack([x * e1[i] + y * e2[i] + z * b[i] for i in range(3)])
        return vectors, along > 0.0


def _along(vectors: np.ndarray, axis: list) -> np.ndarray:
    """Return ``v . axis`` row by row (element by element, not BLAS: block-free)."""
    return vectors[:, 0] * axis[0] + vectors[:, 1] * axis[1] + vectors[:, 2] * axis[2]


def _turned(vectors: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """
    Return each of ``vectors`` turned by its rotation vector (Rodrigues' formula), row by row.

    ``v cos a + (k x v) sin a + k (k . v)(1 - cos a)``, ``k`` the unit axis, ``a`` the angle.
    """
    angle = np.sqrt((rotations * rotations).sum(axis=1))
    safe = np.where(angle > 0.0, angle, 1.0)
    axis = rotations / safe[:, None]
    cos, sin = np.cos(angle)[:, None], np.sin(angle)[:, None]
    along = (axis * vectors).sum(axis=1)[:, None]
    return vectors * cos + _cross(axis, vectors) * sin + axis * along * (1.0 - cos)


__all__ = [
    'ARCSEC',
    'IMU_ROW',
    'Imu',
    'MAGNETIC_FIELD_ROW',
    'Magnetometer',
    'NOT_PROVIDED',
    'SI',
    'StarTracker',
    'SunSensor',
    'body_frame',
]
