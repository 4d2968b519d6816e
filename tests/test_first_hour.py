"""Issue 34, a light first hour: what a newcomer meets on the base install. load_robot without the robots extra
names the extra; a checkout's path to a bundled model says the bare name loads it."""

import pathlib

import pytest

import vibdyn as vd
from vibdyn.io import robots


def test_load_robot_without_the_robots_extra_names_the_extra(monkeypatch):
    monkeypatch.setattr(robots, "_ROBOTS_DIR", [])  # forget the folder found, and find none (as where it is missing)
    monkeypatch.delenv("EXAMPLE_ROBOT_DATA_MODEL_DIR", raising=False)
    monkeypatch.setattr(pathlib.Path, "is_dir", lambda self: False)
    with pytest.raises(vd.ModelError) as e:
        vd.load_robot("ur5")
    message = str(e.value)
    assert message.startswith("robot 'ur5': the robots of example-robot-data are not installed")
    assert "pip install 'vibdyn[robots]'" in message


def test_a_checkout_path_to_a_bundled_model_names_the_bare_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(vd.SceneFileError) as e:
        vd.load_scene("models/rod_pivot.toml")
    assert "the bundled model 'rod_pivot' loads by its bare name: vd.load_scene('rod_pivot')" in str(e.value)
    assert vd.load_scene("rod_pivot").name == "rod_pivot"
