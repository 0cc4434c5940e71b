"""Scene files: the built-in default, and errors that name the file, the field path and the reason."""

from pathlib import Path

import pytest

from torquefree_ros.core.scene import SceneError, default_scene, load_scene

REPO = Path(__file__).resolve().parents[1]


def test_the_default_scene_file_is_the_built_in_default():
    scene = load_scene(REPO / "config" / "scenes" / "default.yaml")
    built_in = default_scene()
    assert (scene.inertia, scene.angular_velocity, scene.orientation, scene.effects, scene.description) == (
        built_in.inertia, built_in.angular_velocity, built_in.orientation, built_in.effects, built_in.description)
    assert built_in.torque_free


def test_a_minimal_scene_from_the_contract_loads(tmp_path):
    path = tmp_path / "s.yaml"
    path.write_text("body:\n  inertia: [3, 2, 1]\ninitial:\n  angular_velocity: [0.001, 1.0, 0.001]\n"
                    "  orientation: [0.0, 0.0, 0.0, 1.0]\neffects: []\n")
    scene = load_scene(path)
    assert scene.inertia == (3.0, 2.0, 1.0) and scene.angular_velocity == (0.001, 1.0, 0.001)


@pytest.mark.parametrize(
    "text, where, reason",
    [
        ("body: {inertia: [3, 2, 1]}\n", "initial", "missing"),
        ("body: {inertia: [3, 2, 1]}\ninital: {angular_velocity: [0, 0, 1]}\n", "inital", "did you mean 'initial'"),
        ("body: {inertia: [1, 1, 5]}\ninitial: {angular_velocity: [0, 0, 1]}\n", "body.inertia", "triangle inequality"),
        ("body: {inertia: [3, 2]}\ninitial: {angular_velocity: [0, 0, 1]}\n", "body.inertia", "3 or 6"),
        ("body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, .nan, 1]}\n", "initial.angular_velocity", "finite"),
        ("body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1], orientation: [0, 0, 0, 0]}\n",
         "initial.orientation", "zero quaternion"),
        ("body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: 'fast'}\n", "initial.angular_velocity", "list of numbers"),
        ("body: {inertia: [3, 2, 1], mass: 2}\ninitial: {angular_velocity: [0, 0, 1]}\n", "body.mass", "unknown key"),
        ("body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1]}\neffects: [{warp_drive: {}}]\n",
         "effects[0]", "unknown effect 'warp_drive'"),
        ("body: {inertia: [3, 2, 1]}\ninitial: {angular_velocity: [0, 0, 1]}\neffects: {damper: {}}\n",
         "effects", "expected a list"),
        ("[1, 2, 3]\n", "(top level)", "expected a mapping"),
        ("body: [unclosed\n", "", "not valid YAML"),
    ],
)
def test_bad_scenes_name_the_file_the_field_and_the_reason(tmp_path, text, where, reason):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(SceneError) as error:
        load_scene(path)
    message = str(error.value)
    assert message.startswith(f"{path}: {where}"), message
    assert reason in message, message


def test_a_missing_scene_file_names_the_path():
    with pytest.raises(SceneError, match=r"^scene: cannot read '/no/such/scene.yaml'"):
        load_scene("/no/such/scene.yaml")
