"""study.scenes: the shipped scenes are the repo's scenes/*.toml, each a valid study; a study
argument is a file when one exists, else a scene's name; an unknown name's error names them."""
from __future__ import annotations

import pytest

from hertzmap.study.scenes import load_scene_or_file, scene_paths, study_path
from hertzmap.study.spec import StudyError, load_study
from tests.helpers import REPO


def test_the_scenes_are_the_repos_study_files_and_each_is_valid():
    scenes = scene_paths()
    assert sorted(scenes) == sorted(p.stem for p in (REPO / "scenes").glob("*.toml"))
    for name, path in scenes.items():
        assert path.read_text() == (REPO / "scenes" / f"{name}.toml").read_text()
        assert load_study(path).name == name


def test_a_name_is_a_scene_unless_a_file_of_that_name_exists(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert study_path("default") == scene_paths()["default"]
    assert study_path("default.toml") == scene_paths()["default"]
    (tmp_path / "default.toml").write_text('[grid]\nomega = [1.0]\nsigma = [0.1]\nzeta = 0.01\n')
    assert study_path("default.toml").resolve() == (tmp_path / "default.toml").resolve()
    assert load_scene_or_file("default.toml").size == 1


def test_an_unknown_name_says_which_scenes_there_are(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(StudyError) as err:
        load_scene_or_file("nosuch")
    assert err.value.field == "file"
    assert "cannot read study file 'nosuch'" in str(err.value)
    assert "default" in str(err.value) and "vibro_impact" in str(err.value)
    with pytest.raises(StudyError) as err:           # a path: no scene is meant
        load_scene_or_file(tmp_path / "nosuch.toml")
    assert "scene" not in str(err.value)
