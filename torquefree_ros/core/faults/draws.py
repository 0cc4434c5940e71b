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
A fault's seeded draws: 8 uniforms a sample from a counter-based generator.

Fault ``index`` (its place in its list) of a run seeded ``seed`` draws at sample ``j`` the 8
uniforms of ``Philox`` (4 x 64 bits, 10 rounds) keyed by ``SeedSequence(seed,
spawn_key=(FAULT_DRAWS, index))`` at counter ``2 j`` (two counter steps, 8 draws, a sample): a
sample's draws depend on nothing else, however samples are cut into blocks.

:func:`uniforms` (:func:`keyed_uniforms`) draws a block of samples of one fault through numpy's
``Philox``;
:func:`uniforms_at` draws one sample of many faults at once (a plant batch's bodies) by the same
rounds written in numpy's integer arithmetic (Salmon et al. 2011, "Parallel random numbers: as easy
as 1, 2, 3", the Random123 constants numpy uses), the same bits; :func:`normals` turns a row's
first four uniforms into three standard normals (Box and Muller:
``sqrt(-2 ln u1) (cos 2 pi u2, sin 2 pi u2)``).
"""

from __future__ import annotations

import math

import numpy as np

#: the first spawn key of fault draws: apart from a sensor's own processes (1, 2, ...)
FAULT_DRAWS = 1000
DRAWS_PER_SAMPLE = 8  # two Philox counter steps of four 64-bit words

_KEY_STEPS = (np.uint64(0x9E3779B97F4A7C15), np.uint64(0xBB67AE8584CAA73B))
_ROUNDS = 10
_LOW = np.uint64(0xFFFFFFFF)
_32 = np.uint64(32)
#: the multipliers of words 0 and 2, as a column, and their 32-bit halves
_MULTIPLIERS = np.array([[0xD2E7470EE14C6C93], [0xCA5A826395121157]], dtype=np.uint64)
_MULTIPLIER_LOW, _MULTIPLIER_HIGH = _MULTIPLIERS & _LOW, _MULTIPLIERS >> _32
_53 = np.uint64(11)  # a double's 53 bits: the word shifted right by 11
_TO_UNIT = 1.0 / 9007199254740992.0  # 2**-53: numpy's next_double


def fault_key(seed: int, index: int) -> np.ndarray:
    """Return the Philox key (two 64-bit words) of fault ``index`` of a run seeded ``seed``."""
    return np.random.SeedSequence(seed, spawn_key=(FAULT_DRAWS, index)).generate_state(
        2, np.uint64
    )


def uniforms(seed: int, index: int, first: int, stop: int) -> np.ndarray:
    """Return the ``(stop - first, 8)`` uniforms of fault ``index`` at samples ``first ..``."""
    return keyed_uniforms(fault_key(seed, index), first, stop)


def keyed_uniforms(key: np.ndarray, first: int, stop: int) -> np.ndarray:
    """Return the ``(stop - first, 8)`` uniforms of the fault keyed ``key`` at ``first ..``."""
    bits = np.random.Philox(key=key)
    bits.advance(2 * first)  # a counter step is 4 draws of 64 bits: 2 steps a sample
    return np.random.Generator(bits).random((stop - first, DRAWS_PER_SAMPLE))


def uniforms_at(keys: np.ndarray, j) -> np.ndarray:
    """
    Return the 8 uniforms at sample ``j`` of the faults keyed ``keys`` (``(n, 2)``): ``(n, 8)``.

    ``j``: one sample, or one a fault. Bit for bit :func:`uniforms` of each: numpy's ``Philox``
    steps its counter before each block, so sample ``j`` reads counters ``2 j + 1`` and ``2 j +
    2``; both blocks of every fault go through the rounds together.
    """
    keys = np.asarray(keys, dtype=np.uint64)
    count = keys.shape[0]
    base = np.broadcast_to(np.asarray(j, dtype=np.uint64), (count,)) * np.uint64(2)
    counter = np.concatenate([base + np.uint64(1), base + np.uint64(2)])
    words = _philox(counter, np.tile(keys[:, 0], 2), np.tile(keys[:, 1], 2))
    unit = (words >> _53) * _TO_UNIT  # (4, 2 n): word, then block and fault
    return unit.reshape(4, 2, count).transpose(2, 1, 0).reshape(count, DRAWS_PER_SAMPLE)


def _philox(counter: np.ndarray, k0: np.ndarray, k1: np.ndarray) -> np.ndarray:
    """
    Return Philox4x64-10's four words ``(4, n)`` of the counters ``(counter, 0, 0, 0)``.

    Under keys ``k0, k1``; each round's two products (of words 0 and 2) are taken together.
    """
    zero = np.zeros_like(counter)
    multiplied = np.stack([counter, zero])  # words 0 and 2
    c1, c3 = zero, zero
    with np.errstate(over='ignore'):  # (words wrap modulo 2**64, as the C rounds do)
        for round_ in range(_ROUNDS):
            if round_:
                k0, k1 = k0 + _KEY_STEPS[0], k1 + _KEY_STEPS[1]
            high, low = _multiply(multiplied)
            multiplied = np.stack([high[1] ^ c1 ^ k0, high[0] ^ c3 ^ k1])
            c1, c3 = low[1], low[0]
    return np.stack([multiplied[0], c1, multiplied[1], c3])


def _multiply(b: np.ndarray) -> tuple:
    """
    Return the high and low words of the rows of ``b`` (2, n) times the multipliers.

    The 128-bit products, from 32-bit halves.
    """
    b_lo, b_hi = b & _LOW, b >> _32
    low_low, low_high, high_low = _MULTIPLIER_LOW * b_lo, _MULTIPLIER_LOW * b_hi, (
        _MULTIPLIER_HIGH * b_lo
    )
    middle = (low_low >> _32) + (low_high & _LOW) + (high_low & _LOW)
    high = _MULTIPLIER_HIGH * b_hi + (low_high >> _32) + (high_low >> _32) + (middle >> _32)
    return high, _MULTIPLIERS * b


def normals(draws: np.ndarray) -> np.ndarray:
    """Return three standard normals a row from its first four uniforms (Box and Muller)."""
    radius = np.sqrt(-2.0 * np.log1p(-draws[:, 0:2]))  # 1 - u in (0, 1]: a finite log
    angle = 2.0 * math.pi * draws[:, 2:4]
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle)])[:, :3]


__all__ = [
    'DRAWS_PER_SAMPLE',
    'FAULT_DRAWS',
    'fault_key',
    'keyed_uniforms',
    'normals',
    'uniforms',
    'uniforms_at',
]
