"""The scenes shipped with hertzmap: the study files of the repo's studies/ folder, installed as
package data of ``hertzmap.scenes``, so that ``hertzmap run default`` works from any folder.

A study argument is a path when a file of that name exists, else the name of a scene.
"""
from __future__ import annotations

from importlib import resources
from pathlib import Path

from hertzmap.study.spec import Study, StudyError, load_study

#: the package the scenes are installed in (pyproject.toml maps it to studies/)
SCENES_PACKAGE = "hertzmap.scenes"
SUFFIX = ".toml"


def scene_paths() -> dict[str, Path]:
    """Every shipped scene: name -> its study file, sorted by name."""
    folder = Path(str(resources.files(SCENES_PACKAGE)))
    return {p.stem: p for p in sorted(folder.glob("*" + SUFFIX))}


def study_path(arg: str | Path) -> Path:
    """The study file ``arg`` names: an existing file, else a scene (``default``, or
    ``default.toml``). Raises StudyError("file", ...) naming the scenes when neither fits."""
    path = Path(arg)
    if path.is_file():
        return path
    scenes = scene_paths()
    name = path.name.removesuffix(SUFFIX)
    if path.parent == Path(".") and name in scenes:
        return scenes[name]
    raise StudyError("file", f"no study file {str(arg)!r} and no scene of that name "
                             f"(scenes: {', '.join(scenes)}; hertzmap scenes describes them)")


def load_scene_or_file(arg: str | Path) -> Study:
    """load_study of study_path(arg)."""
    return load_study(study_path(arg))
