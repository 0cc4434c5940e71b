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
Command-line manners of every console script, run as a user runs them.

The scripts are this environment's bin/ ones, installed by the README's commands. Checked: --help,
Ctrl-C / SIGTERM, closed pipes, progress only on a terminal, hand-typed input.
"""

from __future__ import annotations

import os
from pathlib import Path
import pty
import select
import signal
import subprocess
import sys
import time

from bag_checks import read_with_mcap, read_with_rosbags, stamps_and_last_messages
from conftest import PROCESS_TIMEOUT
import numpy as np
import pytest
from torquefree_ros.cli.common import Progress

BIN = Path(sys.prefix) / 'bin'
SCRIPTS = [
    'torquefree_sim',
    'torquefree_propagate',
    'torquefree_bag',
    'torquefree_record',
    'torquefree_play',
    'torquefree_plot',
    'torquefree_bench',
    'torquefree_campaign',
]
HAND_TYPED = [0.2, 0.1, -0.3, 0.927]  # |q| = 0.99966: four typed digits
TIMEOUT = PROCESS_TIMEOUT  # (a script's start-up re-executes the interpreter: the bootstrapper)


def _run(*argv, **kwargs):
    return subprocess.run(
        [str(BIN / argv[0]), *argv[1:]], capture_output=True, text=True, timeout=TIMEOUT, **kwargs
    )


@pytest.mark.parametrize('script', SCRIPTS)
def test_every_script_is_installed_and_its_help_exits_0(script):
    result = _run(script, '--help')
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith('usage:') and 'Traceback' not in result.stderr


def test_sim_help_lists_every_parameter_with_default_and_starts_no_node():
    from torquefree_ros.ros.parameters import SPECS

    started = time.monotonic()
    result = _run('torquefree_sim', '--help')
    assert result.returncode == 0
    for spec in SPECS:
        assert f'  {spec.name} (default ' in result.stdout, spec.name
    assert (
        'publish_rate (default 100.0)' in result.stdout
        and "record_bag (default '', read-only)" in result.stdout
    )
    assert 'start:' not in result.stdout + result.stderr  # the node never started
    assert time.monotonic() - started < TIMEOUT


def test_bag_help_shows_required_arguments_units_and_defaults():
    text = _run('torquefree_bag', '--help').stdout
    assert 'usage: torquefree_bag SCENE --duration SECONDS --rate HZ --output BAG_DIR' in text
    assert 'required (unless --reindex)' in text
    for piece in (
        'simulated time, s',
        'samples per simulated second, Hz',
        '(default: none, like rosbag2)',
        '(default: body)',
        '(default: world)',
        '(default: 0)',
        'explorer1',
    ):
        assert piece in text, piece


def test_bag_missing_arguments_are_named():
    result = _run('torquefree_bag', 'default', '--rate', '10')
    assert result.returncode == 2 and 'missing --duration, --output' in result.stderr


def test_a_closed_pipe_ends_quietly():
    shell = f"'{BIN / 'torquefree_propagate'}' --duration 100000 --rate 1000 | head -n 2"
    result = subprocess.run(
        ['bash', '-c', f'set -o pipefail; {shell}'],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert (
        result.stdout.splitlines()[0].startswith('t,w_x') and len(result.stdout.splitlines()) == 2
    )
    assert result.stderr == ''
    assert result.returncode == 141  # 128 + SIGPIPE, as for any Unix tool cut off by `head`


def _interrupt_when_output_appears(argv, sig, tmp_path, delay=0.5):
    process = subprocess.Popen(
        [str(BIN / argv[0]), *argv[1:]],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
    )
    try:
        deadline = time.monotonic() + TIMEOUT
        while not any(tmp_path.rglob('*.mcap')) and time.monotonic() < deadline:
            time.sleep(0.05)
        time.sleep(delay)  # into the work
        process.send_signal(sig)
        out, err = process.communicate(timeout=TIMEOUT)
    finally:  # (a node left running would publish into the next session given this domain)
        process.kill()
    return process.returncode, out, err


# the bag writes ~a million samples a second: these delays stop it after none to a few hundred
# thousand
@pytest.mark.parametrize(
    'sig, delay',
    [(signal.SIGINT, 0.0), (signal.SIGINT, 0.07), (signal.SIGTERM, 0.16), (signal.SIGTERM, 0.3)],
    ids=['SIGINT-0', 'SIGINT-0.07', 'SIGTERM-0.16', 'SIGTERM-0.3'],
)
def test_an_interrupted_bag_is_complete_and_says_so(tmp_path, sig, delay):
    """
    Ctrl-C / SIGTERM at any moment leaves a complete bag and exit status 130.

    The bag closes at the next block with every sample written so far; both independent readers
    open it and agree with metadata.yaml.
    """
    status, _, err = _interrupt_when_output_appears(
        ['torquefree_bag', 'default', '--duration', '1e6', '--rate', '1000', '--output', 'long'],
        sig,
        tmp_path,
        delay,
    )
    assert status == 130, err
    assert (
        'Traceback' not in err
        and 'torquefree_bag: interrupted: long is a complete bag of the first' in err
    )
    samples = int(err.split('the first ')[1].split()[0])
    # ~a million messages: both readers index them all and decode each topic's last (full decoding
    # of every message is test_bag's; here it would take minutes)
    log_times, counts, last_by_mcap, last_by_rosbags = stamps_and_last_messages(tmp_path / 'long')
    assert counts == {'/angular_velocity': samples, '/attitude': samples} and samples > 0
    assert {topic: len(times) for topic, times in log_times.items()} == counts
    for topic in counts:
        # a gap-free prefix of the run
        assert log_times[topic] == [k * 1_000_000 for k in range(samples)]
        for last in (last_by_mcap[topic], last_by_rosbags[topic]):
            assert (
                last.header.stamp.sec * 1_000_000_000 + last.header.stamp.nanosec
                == log_times[topic][-1]
            )
    from torquefree_ros.bag import BagReader

    reader = BagReader(tmp_path / 'long')
    assert reader.complete and reader.message_count == 2 * samples


def test_absurd_bag_sizes_are_refused_before_anything_is_written(tmp_path):
    result = _run(
        'torquefree_bag',
        'default',
        '--duration',
        '1e9',
        '--rate',
        '1e6',
        '--output',
        str(tmp_path / 'b'),
    )
    assert (
        result.returncode == 2
        and 'at most 1e+10' in result.stderr
        and not (tmp_path / 'b').exists()
    )
    result = _run(
        'torquefree_bag',
        'default',
        '--duration',
        '3e9',
        '--rate',
        '1',
        '--output',
        str(tmp_path / 'b'),
    )
    assert result.returncode == 2 and '2^31 s' in result.stderr and not (tmp_path / 'b').exists()


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_the_recording_node_stops_on_a_signal_cleanly_with_its_bag(tmp_path, sig):
    status, out, err = _interrupt_when_output_appears(
        ['torquefree_sim', '--ros-args', '-p', 'record_bag:=run', '-p', 'publish_rate:=200.0'],
        sig,
        tmp_path,
    )
    assert status == 0, err
    # no "Failed to publish log message to rosout"
    assert 'Traceback' not in err and 'rosout' not in err
    log = out + err
    assert 'start: publishing /angular_velocity, /attitude; recording bag run;' in log
    assert 'bag closed: run (' in log
    messages, _ = read_with_rosbags(tmp_path / 'run')  # the bag is complete
    assert len(messages['/angular_velocity']) == len(messages['/attitude']) > 0


def test_progress_is_shown_on_a_terminal_and_not_when_piped(tmp_path):
    # ~3 s of work
    argv = [str(BIN / 'torquefree_bag'), 'default', '--duration', '300', '--rate', '1000']
    piped = subprocess.run(
        [*argv, '--output', str(tmp_path / 'piped')],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
    )
    assert piped.returncode == 0 and 'ETA' not in piped.stderr and piped.stderr == ''
    leader, follower = pty.openpty()
    process = subprocess.Popen(
        [*argv, '--output', str(tmp_path / 'tty')],
        stdout=subprocess.PIPE,
        stderr=follower,
        text=True,
    )
    os.close(follower)
    seen = b''
    while process.poll() is None or select.select([leader], [], [], 0.1)[0]:
        if select.select([leader], [], [], 0.1)[0]:
            try:
                seen += os.read(leader, 4096)
            except OSError:
                break
    process.wait(timeout=TIMEOUT)
    os.close(leader)
    assert process.returncode == 0
    assert b'samples/s, ETA' in seen and b'simulated' in seen


def test_progress_line_reports_rate_simulated_time_and_eta():
    progress = Progress(rate_hz=100.0, streams=1)
    line = progress.line(done=5_000, total=10_000, elapsed=2.0)
    assert line == '5,000/10,000 samples (50 %), simulated 50 s, 2,500 samples/s, ETA 0:02'


# -- hand-typed quaternions: one rule for the API, scene files, the CLI and the node
# (test_sim_node) --------


def test_cli_accepts_a_hand_typed_quaternion_and_prints_the_normalised_one():
    result = _run(
        'torquefree_propagate',
        '--orientation',
        *map(str, HAND_TYPED),
        '--duration',
        '0',
        '--rate',
        '1',
    )
    assert result.returncode == 0, result.stderr
    q0 = np.array([float(x) for x in result.stdout.splitlines()[1].split(',')[4:]])
    np.testing.assert_allclose(
        q0, np.array(HAND_TYPED) / np.linalg.norm(HAND_TYPED), rtol=0, atol=2e-16
    )


def test_cli_refuses_a_quaternion_far_from_unit_with_the_normalised_value():
    result = _run('torquefree_propagate', '--orientation', '0', '0', '0.5', '0.5')
    assert result.returncode == 2 and 'Traceback' not in result.stderr
    assert (
        'orientation: expected a unit quaternion' in result.stderr
        and '[0, 0, 0.707107, 0.707107]' in result.stderr
    )


def test_sweep_bag_holds_every_member_in_its_own_namespace(tmp_path):
    result = _run(
        'torquefree_bag',
        'energy_sweep',
        '--duration',
        '1',
        '--rate',
        '10',
        '--output',
        str(tmp_path / 's'),
    )
    assert result.returncode == 0, result.stderr
    messages = read_with_mcap(tmp_path / 's')
    topics = sorted(messages)
    assert topics == sorted(
        f'/member_{j}/{name}' for j in range(9) for name in ('angular_velocity', 'attitude')
    )
    # 1 s at 10 Hz: samples k = 0 ... 10, both ends included (CONTRACT, torquefree_bag)
    assert all(len(messages[topic]) == 11 for topic in topics)
