"""Hostile input: malformed parameter messages and fuzzed parameter values sent over DDS, and
mutated scene files. Every input gets a clear refusal (or a Scene) in bounded time and size, and the
node keeps publishing. Budgets are fixed (hypothesis ``max_examples``) so CI time is bounded."""

from __future__ import annotations

import os
import string
import tempfile
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rcl_interfaces.msg import Parameter as ParameterMessage
from rcl_interfaces.msg import ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters, SetParametersAtomically

from sim_harness import connected_harness
from torquefree_ros.core.scene import MAX_SCENE_BYTES, Scene, SceneError, load_scene
from torquefree_ros.ros.guarded_parameters import MAX_REASON_LENGTH
from torquefree_ros.ros.parameters import SPECS

MAX_MESSAGE = MAX_REASON_LENGTH + 40  # a refusal is one line; "… (N characters)" may follow the clip
SCENE = ("description: fuzz\nbody:\n  inertia: [3.0, 2.0, 1.0]\ninitial:\n  angular_velocity: [0.3, 0.2, 1.0]\n"
         "  orientation: [0.0, 0.0, 0.0, 1.0]\neffects:\n  - damper: {inertia: 0.05, damping: 0.01}\n"
         "  - imu: {gyro_noise_density: 1.0e-4, seed: 42}\naccuracy: 1.0e-9\n")


@pytest.fixture(scope="module")
def harness():
    with connected_harness(publish_rate=100.0) as h:
        yield h


def _call(harness, service_type, name, request):
    client = harness.client.create_client(service_type, f"{harness.node.get_fully_qualified_name()}/{name}")
    try:
        harness.spin_until(client.service_is_ready, what=name)
        return harness.wait_future(client.call_async(request), name)
    finally:
        harness.client.destroy_client(client)


def _still_publishing(harness):
    last = harness.pairs()[-1][0] if harness.pairs() else None
    harness.wait_samples(3, after=last)


def _raw(name, kind, **fields):
    return ParameterMessage(name=name, value=ParameterValue(type=kind, **fields))


@pytest.mark.parametrize("message, reason", [
    (_raw("publish_rate", 99), "publish_rate: 99 is not a parameter type"),
    (_raw("inertia", 255), "inertia: 255 is not a parameter type"),
    (_raw("x" * 300, ParameterType.PARAMETER_DOUBLE, double_value=1.0), "a parameter name has 1 to 256 characters"),
    (_raw("inertia", ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=[1e308, 1e308, 1e308]), "overflows"),
    (_raw("inertial_frame", ParameterType.PARAMETER_STRING, string_value="w" * 1_000_000), "frame id"),
    (_raw("scene", ParameterType.PARAMETER_STRING, string_value="/dev/zero"), "scene_directories"),
    (_raw("scene", ParameterType.PARAMETER_STRING, string_value="/" + "s" * 256), "nor a file under scene_directories"),
    (_raw("scene", ParameterType.PARAMETER_STRING, string_value=os.path.join(tempfile.gettempdir(), "s" * 256)),
     "cannot read"),  # inside scene_directories: read, and refused for its name (ENAMETOOLONG)
])
def test_malformed_parameter_messages_are_refused_and_the_node_keeps_publishing(harness, message, reason):
    for service_type, service in ((SetParameters, "set_parameters"), (SetParametersAtomically, "set_parameters_atomically")):
        request = service_type.Request(parameters=[message])
        response = _call(harness, service_type, service, request)
        result = response.results[0] if service == "set_parameters" else response.result
        assert not result.successful and reason in result.reason, result.reason
        assert len(result.reason) <= MAX_MESSAGE
    _still_publishing(harness)


def test_get_parameters_with_odd_names_answers(harness):
    response = _call(harness, GetParameters, "get_parameters", GetParameters.Request(names=["", "x" * 10_000, "inertia"]))
    assert response is not None
    _still_publishing(harness)


_VALUE = st.one_of(
    st.builds(lambda t: ParameterValue(type=t), st.integers(0, 255)),
    st.builds(lambda b: ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=b), st.booleans()),
    st.builds(lambda i: ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=i),
              st.integers(-2**63, 2**63 - 1)),
    st.builds(lambda d: ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=d), st.floats()),
    st.builds(lambda s: ParameterValue(type=ParameterType.PARAMETER_STRING, string_value=s),
              st.text(string.printable, max_size=300)),
    st.builds(lambda a: ParameterValue(type=ParameterType.PARAMETER_DOUBLE_ARRAY, double_array_value=a),
              st.lists(st.floats(), max_size=8)),
    st.builds(lambda a: ParameterValue(type=ParameterType.PARAMETER_INTEGER_ARRAY, integer_array_value=a),
              st.lists(st.integers(-2**63, 2**63 - 1), max_size=8)),
    st.builds(lambda a: ParameterValue(type=ParameterType.PARAMETER_STRING_ARRAY, string_array_value=a),
              st.lists(st.text(max_size=20), max_size=4)),
)
_NAME = st.one_of(st.sampled_from([spec.name for spec in SPECS]), st.text(string.ascii_letters + "_.", max_size=30))


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                  HealthCheck.too_slow])
@given(names=st.lists(_NAME, min_size=1, max_size=3), values=st.lists(_VALUE, min_size=3, max_size=3))
def test_fuzzed_parameter_requests_never_stop_the_node(harness, names, values):
    request = SetParameters.Request(parameters=[ParameterMessage(name=n, value=v) for n, v in zip(names, values)])
    response = _call(harness, SetParameters, "set_parameters", request)
    assert len(response.results) == len(request.parameters)
    assert all(len(result.reason) <= MAX_MESSAGE for result in response.results)
    assert harness.node.sample_loop.running and not harness.node.sample_loop.failure
    # whatever was accepted, the node can still be reset or refuses with a reason
    harness.reset()


# -- scene files --------------------------------------------------------------------------------------

def _load(tmp_path, text: str):
    path = tmp_path / "fuzz.yaml"
    path.write_text(text)
    started = time.monotonic()
    try:
        return load_scene(path)
    except SceneError as error:
        message = str(error)
        assert message.startswith(str(path)) or message.startswith("scene:"), message
        assert len(message) < 2000, message[:300]
        return error
    finally:
        assert time.monotonic() - started < 5.0


def _billion_laughs(levels: int = 12) -> str:
    """Each level a list of ten aliases of the one before: 10^12 values once expanded."""
    lines = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    lines += [f"a{i}: &a{i} [{', '.join([f'*a{i - 1}'] * 10)}]" for i in range(1, levels)]
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("text, reason", [
    (_billion_laughs(), "too large once its aliases are expanded"),
    ("body: " + "[" * 5000 + "]" * 5000 + "\n", "nested too deeply"),
    (SCENE.replace("[3.0, 2.0, 1.0]", "[3" + "0" * 400 + ", 2, 1]"), "body.inertia: every entry must be finite"),
    (SCENE + "body: {inertia: [1, 2, 3]}\n", "duplicate key 'body' (first at line 2)"),
    (SCENE.replace("seed: 42", "seed: 0b"), ""),
    (SCENE.replace("accuracy: 1.0e-9", "accuracy: 0o99"), ""),
    ("\x00\x01binary", "not valid YAML"),
])
def test_hostile_scene_files_are_refused_quickly_with_a_short_reason(tmp_path, text, reason):
    result = _load(tmp_path, text)
    if reason:
        assert isinstance(result, SceneError) and reason in str(result), str(result)[:300]


def test_special_and_huge_files_are_not_read(tmp_path):
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    with pytest.raises(SceneError, match="is not a regular file"):
        load_scene(fifo)  # would block forever if opened for a blocking read
    with pytest.raises(SceneError, match="is not a regular file"):
        load_scene("/dev/zero")
    big = tmp_path / "big.yaml"
    big.write_text(SCENE + "#" * MAX_SCENE_BYTES)
    with pytest.raises(SceneError, match="is larger than 1,048,576 bytes"):
        load_scene(big)


_MUTATION = st.tuples(st.integers(0, len(SCENE)), st.integers(0, 6),
                      st.sampled_from(["", "*", "&a ", "[", "{", "]", "}", ":", "-", " ", "\n", "\t", "!!int ",
                                       "!!binary ", "1e400", "9" * 30, ".nan", "~", "'", '"', "? ", "|", "&b [*a, *a]"]))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(mutations=st.lists(_MUTATION, min_size=1, max_size=6))
def test_mutated_scene_files_give_a_scene_or_a_scene_error(tmp_path, mutations):
    text = SCENE
    for position, length, insert in mutations:
        position = min(position, len(text))
        text = text[:position] + insert + text[position + length:]
    result = _load(tmp_path, text)
    assert isinstance(result, (Scene, SceneError))
    if isinstance(result, Scene):  # what is accepted gives finite samples or refuses to start
        from torquefree_ros.core.simulation import Simulation

        try:
            block = Simulation(result.propagator(), 10.0).samples(0, 3)
        except ValueError:
            return
        assert block.omega_B.shape == (3, 3)


# -- damaged bags ---------------------------------------------------------------------------------------

@pytest.fixture
def good_bag(tmp_path):
    from torquefree_ros.cli.bag import main as bag_main

    bag = tmp_path / "good"
    # 300 s at 100 Hz: 4 chunks of 1 MiB, so a flipped byte in the second leaves the first whole
    assert bag_main(["default", "--duration", "300", "--rate", "100", "--output", str(bag)]) == 0
    return bag


def _play(bag, capsys):
    from torquefree_ros.cli.play import main as play_main

    status = play_main(["torquefree_play", str(bag), "--rate", "1000"])
    return status, capsys.readouterr().err


@pytest.mark.parametrize("metadata, reason", [
    (b"\xff\xfe\x00junk", "not UTF-8 text"),
    (_billion_laughs().encode(), "too large once its aliases are expanded"),
    (b"rosbag2_bagfile_information: [1, 2]\n", "unreadable metadata.yaml"),
])
def test_players_and_reindex_refuse_a_damaged_metadata_file_in_one_line(good_bag, capsys, metadata, reason):
    from torquefree_ros.cli.bag import main as bag_main

    (good_bag / "metadata.yaml").write_bytes(metadata)
    started = time.monotonic()
    status, err = _play(good_bag, capsys)
    assert status == 1 and reason in err and "Traceback" not in err and len(err.splitlines()) == 1, err
    assert bag_main(["--reindex", str(good_bag)]) == 1
    assert reason in capsys.readouterr().err
    assert time.monotonic() - started < 5.0


def test_a_fifo_in_place_of_the_mcap_file_is_refused_not_opened(good_bag, capsys):
    (good_bag / "good_0.mcap").unlink()
    os.mkfifo(good_bag / "good_0.mcap")
    status, err = _play(good_bag, capsys)
    assert status == 1 and "is not a regular file" in err


def test_flipped_bytes_are_reported_with_what_was_lost_and_reindex_keeps_the_rest(good_bag, capsys):
    from bag_checks import read_with_mcap, read_with_rosbags
    from torquefree_ros.bag import BagError, BagReader
    from torquefree_ros.cli.bag import main as bag_main

    data = bytearray((good_bag / "good_0.mcap").read_bytes())
    data[len(data) // 3] ^= 0xFF  # inside a chunk's records
    (good_bag / "good_0.mcap").write_bytes(bytes(data))
    with pytest.raises(BagError, match=r"damaged after \d+ messages .*the rest is lost.*--reindex"):
        for _ in BagReader(good_bag).messages():
            pass
    assert bag_main(["--reindex", str(good_bag)]) == 1  # it repaired, and says what was lost
    err = capsys.readouterr().err
    assert "damaged (" in err and "messages before it were kept, everything after it is lost" in err
    kept = BagReader(good_bag)
    assert kept.complete and 0 < kept.message_count < 2 * 30001
    assert sum(len(v) for v in read_with_mcap(good_bag).values()) == kept.message_count
    assert sum(len(v) for v in read_with_rosbags(good_bag)[0].values()) == kept.message_count


@pytest.mark.parametrize("keep", [0.5, 0.0], ids=["half", "header-only"])
def test_a_cut_bag_plays_what_is_readable_and_exits_1(good_bag, capsys, keep):
    path = good_bag / "good_0.mcap"
    data = path.read_bytes()
    path.write_bytes(data[: max(int(len(data) * keep), 8 + 30)])  # magic + a header record at least
    (good_bag / "metadata.yaml").unlink()
    status, err = _play(good_bag, capsys)
    assert status == 1 and "Traceback" not in err, err
    first = err.splitlines()[0]  # then, for the half bag, "played N messages": what was readable went out
    assert ("is incomplete" in first and "--reindex" in first) or "it ends inside its header" in first, err


def test_bag_tools_refuse_a_name_too_long_for_the_file_system(tmp_path, capsys):
    from torquefree_ros.cli.bag import main as bag_main
    from torquefree_ros.cli.record import main as record_main

    name = str(tmp_path / ("b" * 300))
    assert bag_main(["default", "--duration", "1", "--rate", "10", "--output", name]) == 1
    assert record_main(["torquefree_record", "--output", name]) == 1
    err = capsys.readouterr().err
    assert err.count("File name too long") == 2 and "Traceback" not in err


def test_an_output_topic_too_long_for_dds_is_a_scene_error(tmp_path):
    path = tmp_path / "topic.yaml"
    path.write_text("body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1]}\n"
                    f"effects:\n  - euler_angles: {{topic: {'t' * 300}}}\n")
    with pytest.raises(SceneError, match=r"effects\[0\]\.euler_angles\.topic: expected a ROS topic name"):
        load_scene(path)


# -- a full disk at close ---------------------------------------------------------------------------------

def _one_sample_writer(path):
    from torquefree_ros.bag import BagWriter

    writer = BagWriter(path)
    channel = writer.add_topic("/clock", "rosgraph_msgs/msg/Clock")
    writer.write(channel, 5, b"\x00\x01\x00\x00" + bytes(8))
    return writer


def _no_space(*args, **kwargs):
    raise OSError(28, "No space left on device")


def test_no_room_for_metadata_says_the_mcap_is_whole_and_how_to_repair(tmp_path, monkeypatch):
    from torquefree_ros.bag import BagError, BagReader, writer as writer_module
    from torquefree_ros.cli.bag import main as bag_main

    writer = _one_sample_writer(tmp_path / "bag")
    monkeypatch.setattr(writer_module, "write_atomically", _no_space)
    with pytest.raises(BagError) as error:
        writer.close()
    message = str(error.value)
    assert "'bag_0.mcap' is complete, but metadata.yaml could not be written (No space left on device)" in message
    assert "chunk" not in message and f"torquefree_bag --reindex {tmp_path / 'bag'}" in message
    monkeypatch.undo()
    assert bag_main(["--reindex", str(tmp_path / "bag")]) == 0
    assert BagReader(tmp_path / "bag").message_count == 1 and (tmp_path / "bag" / "metadata.yaml").is_file()


def test_no_room_to_rebuild_after_a_write_error_gives_the_repair_command(tmp_path, monkeypatch):
    from torquefree_ros.bag import BagError, BagReader, reader as reader_module
    from torquefree_ros.cli.bag import main as bag_main

    writer = _one_sample_writer(tmp_path / "bag")
    writer.flush()  # the sample's chunk is on disk
    monkeypatch.setattr(writer._mcap, "finish", _no_space)
    monkeypatch.setattr(reader_module, "reindex", _no_space)  # the rebuilt copy finds no room either
    with pytest.raises(BagError) as error:
        writer.close()
    message = str(error.value)
    assert "could not be completed now (No space left on device)" in message
    assert f"free some space, then run `torquefree_bag --reindex {tmp_path / 'bag'}`" in message
    monkeypatch.undo()
    assert bag_main(["--reindex", str(tmp_path / "bag")]) == 0
    assert BagReader(tmp_path / "bag").complete and BagReader(tmp_path / "bag").message_count == 1
