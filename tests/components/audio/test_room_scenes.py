"""Scene files in metres: what they say is refused by name when it cannot be rendered, and what they render."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.components.audio import (
    RoomSceneRenderer, Scene, SceneError, listener_of, load_scene, scene_renderer, shoebox_of,
)
from aiogenomix.components.audio._paths import PathRefused

ROOM = {"dimensions": [6, 4, 3], "rt60": 0.4}


@pytest.mark.parametrize(("scene", "says"), [
    ({"room": {"dimensions": [6, 4], "rt60": 0.4}}, "room.dimensions"),
    ({"room": {"dimensions": [6, 4, 3]}}, "absorption or its rt60"),
    ({"room": {"dimensions": [6, 4, 3], "rt60": 0.4, "absorption": 0.2}}, "absorption or its rt60"),
    ({"room": {"dimensions": [6, 4, 3], "absorption": {"roof": 0.2}}}, "unknown wall"),
    ({"room": {"dimensions": [6, 4, 3], "rt60": 0.4, "colour": "red"}}, "unknown room key"),
    ({"room": {"dimensions": [6, 4, 3], "rt60": 0.4, "max_order": 40}}, "max_order"),
    ({"room": ROOM, "listener": {"x": 9}}, "listener at"),
    ({"room": ROOM, "listener": {"x": 1, "height": 2}}, "listener is"),
    ({"room": ROOM, "sources": [{"azimuth": 30}]}, "position, path, or distance"),
    ({"room": ROOM, "sources": [{"position": [1, 1, 1], "distance": 2}]}, "position, path, or distance"),
    ({"room": ROOM, "sources": [{"position": [7, 1, 1]}]}, "outside the room"),
    ({"room": ROOM, "sources": [{"path": {"waypoints": [[1, 1, 1], [9, 1, 1]], "speed": 1}}]}, "outside the room"),
    ({"room": ROOM, "sources": [{"path": {"waypoints": [[1, 1, 1]], "speed": 0}}]}, "speed"),
    ({"room": ROOM, "head": "spherical"}, "spherical head"),
    ({"sources": [{"type": "file"}]}, "file source"),
    ({"sources": [{"type": "speech", "voice": "robot"}]}, "voice"),
])
def test_a_scene_that_cannot_be_rendered_is_refused_saying_why(scene: dict, says: str) -> None:
    with pytest.raises(SceneError, match=says):
        Scene.from_dict(scene)


def test_azimuth_and_distance_place_a_source_from_the_listener() -> None:
    scene = Scene.from_dict({"room": ROOM, "listener": {"x": 2, "y": 1, "z": 1.2, "facing": 30},
                             "sources": [{"azimuth": 90, "distance": 1.5, "elevation": 10}]})
    assert scene.placed and listener_of(scene).position == (2.0, 1.0, 1.2)
    renderer = scene_renderer(scene, 16_000)
    assert isinstance(renderer, RoomSceneRenderer)
    x, y, z = renderer.positions(0.0)[0]
    assert (x, y, z) == pytest.approx((2.0, 1.0 + 1.5 * np.cos(np.radians(10)), 1.2 + 1.5 * np.sin(np.radians(10))))
    # Without a listener, the head is in the room's middle, 1.5 m up.
    assert listener_of(Scene.from_dict({"room": ROOM})).position == (3.0, 2.0, 1.5)
    assert shoebox_of(ROOM).eyring_rt60() == pytest.approx(0.4)


def test_files_of_a_scene_come_from_the_allowed_directories_only(tmp_path: Path) -> None:
    allowed, elsewhere = tmp_path / "allowed", tmp_path / "elsewhere"
    allowed.mkdir()
    elsewhere.mkdir()
    for name, hrtf in (("outside.json", "../elsewhere/head.sofa"), ("absent.json", "none.sofa")):
        (allowed / name).write_text(json.dumps({"hrtf": hrtf, "sources": [{"azimuth": 30}]}))
    with pytest.raises(PathRefused):
        scene_renderer(load_scene(allowed / "outside.json"), 16_000, roots=[str(allowed)])
    with pytest.raises(SceneError, match="hrtf"):
        scene_renderer(load_scene(allowed / "absent.json"), 16_000, roots=[str(allowed)])
    (allowed / "wav.json").write_text(json.dumps({"sources": [{"type": "file", "file": "none.wav", "distance": 1}]}))
    with pytest.raises(SceneError, match="cannot open"):
        scene_renderer(load_scene(allowed / "wav.json"), 16_000, roots=[str(allowed)])


def test_a_file_talker_plays_once_or_in_a_loop_at_its_level(tmp_path: Path) -> None:
    import soundfile

    # 1 s of noise, heard as loud as the scene's own noise source at the same level and place.
    soundfile.write(tmp_path / "tone.wav", 0.1 * np.random.default_rng(1).standard_normal(16_000), 16_000)
    builtin = scene_renderer(Scene.from_dict({"sources": [{"type": "noise", "distance": 1, "level": -20}]}), 16_000)
    reference = 20 * np.log10(np.sqrt(np.mean(builtin.render_float(32_000, 0.0)[2000:15000] ** 2)))
    for loop in (False, True):
        (tmp_path / "s.json").write_text(json.dumps({"sources": [{"type": "file", "file": "tone.wav", "distance": 1,
                                                                  "level": -20, "loop": loop}]}))
        renderer = scene_renderer(load_scene(tmp_path / "s.json"), 16_000)
        ears = renderer.render_float(32_000, 0.0)
        first, second = ears[2000:15000], ears[18000:]
        assert 20 * np.log10(np.sqrt(np.mean(first**2))) == pytest.approx(reference, abs=0.3)
        assert bool(np.sqrt(np.mean(second**2)) > 0.01) == loop          # -20 dB RMS is 0.1
