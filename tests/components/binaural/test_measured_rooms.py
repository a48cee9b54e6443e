"""Measured rooms: SOFA files of binaural room impulse responses with head orientations, read and rendered.

The files are written here as AES69 lays them out (``MultiSpeakerBRIR``: ``Data.IR`` M × R × E × N, a
``ListenerView`` per measurement) with netCDF4 directly, and as ``SingleRoomMIMOSRIR`` (M × R × N × E) by
sofar, whose verifier checks the layout; the responses are rooms rendered by ``room_response``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from aiogenomix.components.binaural import (
    HrirSet, MeasuredRoomRenderer, Pose, Shoebox, SofaError, read_sofa, read_sofa_room, room_response,
)

RATE = 16_000.0
VIEWS = (0.0, 90.0, 180.0, -90.0)
LISTENER = Pose(3.0, 2.0, 1.5)
EMITTERS = ((4.5, 2.0, 1.5), (3.0, 3.5, 1.5))


@pytest.fixture(scope="module")
def brirs(kemar: HrirSet) -> np.ndarray:
    """(views, emitters, taps, 2): the BRIRs of a 6 × 4 × 3 m room of RT60 0.3 s, the head turned to each view."""
    room = Shoebox.with_rt60((6.0, 4.0, 3.0), 0.3)
    return np.stack([np.stack([room_response(e, LISTENER.turned(v), rate=RATE, seconds=0.25, room=room, hrirs=kemar)
                               for e in EMITTERS]) for v in VIEWS])


def write_multispeaker(path: Path, brirs: np.ndarray) -> None:
    import netCDF4

    views, emitters, taps, _ = brirs.shape
    with netCDF4.Dataset(path, "w") as out:
        out.setncatts({"Conventions": "SOFA", "Version": "1.0", "SOFAConventions": "MultiSpeakerBRIR",
                       "SOFAConventionsVersion": "0.3", "DataType": "FIR", "RoomType": "shoebox", "Title": "test room"})
        for dimension, size in (("I", 1), ("C", 3), ("R", 2), ("E", emitters), ("N", taps), ("M", views)):
            out.createDimension(dimension, size)
        ir = out.createVariable("Data.IR", "f8", ("M", "R", "E", "N"))
        ir[:] = brirs.transpose(0, 3, 1, 2)
        rate = out.createVariable("Data.SamplingRate", "f8", ("I",))
        rate[:] = [RATE]
        view = out.createVariable("ListenerView", "f8", ("M", "C"))
        view[:] = [[np.cos(np.radians(v)), np.sin(np.radians(v)), 0.0] for v in VIEWS]
        view.Type = "cartesian"
        receivers = out.createVariable("ReceiverPosition", "f8", ("R", "C", "I"))
        receivers[:] = [[[0.0], [0.09], [0.0]], [[0.0], [-0.09], [0.0]]]


def test_a_multispeaker_brir_file_reads_back_its_responses(tmp_path: Path, brirs: np.ndarray) -> None:
    write_multispeaker(tmp_path / "room.sofa", brirs)
    room = read_sofa_room(tmp_path / "room.sofa")
    assert room.rate == RATE and room.emitters == 2
    for v, view in enumerate(VIEWS):
        for e in range(2):
            index = room.nearest(e, view + 10.0)
            assert (room.view[index] - view) % 360.0 == pytest.approx(0.0) and room.emitter[index] == e
            assert np.array_equal(room.taps[index], brirs[v, e])
    # A head file is no room, and a room is no head: both refused by name.
    with pytest.raises(SofaError, match="measured room"):
        read_sofa(tmp_path / "room.sofa")


def test_sofars_single_room_mimo_srir_reads_the_same(tmp_path: Path, brirs: np.ndarray) -> None:
    import warnings

    sofar = pytest.importorskip("sofar")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # sofar says the convention's version is preliminary
        data = sofar.Sofa("SingleRoomMIMOSRIR")
        views, emitters, taps, _ = brirs.shape
        data.Data_IR = brirs.transpose(0, 3, 2, 1)                                  # M R N E
        data.Data_SamplingRate = RATE
        data.Data_Delay = np.zeros((1, 2, 1))
        data.ListenerView = np.array([[v, 0.0, 1.0] for v in VIEWS])
        data.ListenerView_Type, data.ListenerView_Units = "spherical", "degree, degree, metre"
        data.ListenerPosition = np.tile(LISTENER.position, (views, 1))
        data.SourcePosition = np.tile(LISTENER.position, (views, 1))
        data.ReceiverPosition = np.array([[90.0, 0.0, 0.09], [-90.0, 0.0, 0.09]])
        data.ReceiverView = np.zeros((2, 3, 1))
        data.ReceiverUp = np.zeros((2, 3, 1))
        data.delete("ReceiverDescriptions")                                      # optional, and sofar's
        data.EmitterPosition = np.array([[0.0, 0.0, 0.0]] * emitters)
        data.EmitterView = np.zeros((emitters, 3, 1))
        data.EmitterUp = np.zeros((emitters, 3, 1))
        data.delete("EmitterDescriptions")                                       # string shapes are fussy
        data.MeasurementDate = np.zeros(views)
        sofar.write_sofa(str(tmp_path / "mimo.sofa"), data)
    room = read_sofa_room(tmp_path / "mimo.sofa")
    assert room.emitters == 2
    index = room.nearest(1, 175.0)
    assert room.view[index] % 360.0 == pytest.approx(180.0) and np.allclose(room.taps[index], brirs[2, 1])


def test_a_turning_head_takes_the_nearest_measurement_without_a_click(tmp_path: Path, brirs: np.ndarray) -> None:
    write_multispeaker(tmp_path / "room.sofa", brirs)
    room = read_sofa_room(tmp_path / "room.sofa")
    tone = 0.5 * np.sin(2 * np.pi * 125.0 * np.arange(16 * 512) / RATE)[np.newaxis]
    still = MeasuredRoomRenderer(RATE, room, [0]).render(tone, 80.0)
    expected = np.stack([np.convolve(tone[0], brirs[1, 0, :, ear])[:tone.shape[1]] for ear in (0, 1)], axis=1)
    assert np.allclose(still, expected, atol=1e-9)
    # The head turns from 0° to 180° over 16 blocks: the responses change at 45° and 135°, faded across a block.
    turning = MeasuredRoomRenderer(RATE, room, [0])
    out = np.concatenate([turning.render(tone[:, k * 512:(k + 1) * 512], 180.0 * (k + 1) / 16) for k in range(16)])
    statics = [MeasuredRoomRenderer(RATE, room, [0]).render(tone, view) for view in (0.0, 90.0, 180.0)]
    bound = 1.1 * max(float(np.max(np.abs(np.diff(s[4000:], axis=0)))) for s in statics)
    assert float(np.max(np.abs(np.diff(out[4000:], axis=0)))) <= bound


def test_a_scene_plays_its_talkers_from_a_measured_rooms_loudspeakers(tmp_path: Path, brirs: np.ndarray) -> None:
    from aiogenomix.components.audio import Scene, SceneError, load_scene, scene_renderer

    write_multispeaker(tmp_path / "room.sofa", brirs)
    (tmp_path / "scene.json").write_text(json.dumps({"room": {"sofa": "room.sofa"}, "seed": 3,
                                                     "sources": [{"type": "noise", "emitter": 1, "level": -20}]}))
    ears = scene_renderer(load_scene(tmp_path / "scene.json"), 16_000).render_float(8000, 90.0)
    noise = 0.1 * np.random.default_rng(3).standard_normal(8000)
    expected = np.stack([np.convolve(noise, brirs[1, 1, :, ear])[:8000] for ear in (0, 1)], axis=1)
    assert np.allclose(ears, expected, atol=1e-9)
    for bad, says in (({"room": {"sofa": "room.sofa"}, "sources": [{"position": [1, 1, 1]}]}, "emitter"),
                      ({"room": {"sofa": "room.sofa"}, "hrtf": "head.sofa"}, "measured it"),
                      ({"sources": [{"emitter": 0}]}, "measured room")):
        with pytest.raises(SceneError, match=says):
            Scene.from_dict(bad)


def test_a_single_room_srir_tells_its_loudspeakers_by_their_positions(tmp_path: Path, brirs: np.ndarray) -> None:
    import netCDF4

    views, emitters, taps, _ = brirs.shape
    with netCDF4.Dataset(tmp_path / "srir.sofa", "w") as out:
        out.setncatts({"Conventions": "SOFA", "SOFAConventions": "SingleRoomSRIR", "DataType": "FIR"})
        for dimension, size in (("I", 1), ("C", 3), ("R", 2), ("N", taps), ("M", views * emitters)):
            out.createDimension(dimension, size)
        # One measurement per loudspeaker and head orientation, the loudspeaker told by SourcePosition.
        ir = out.createVariable("Data.IR", "f8", ("M", "R", "N"))
        ir[:] = brirs.transpose(0, 1, 3, 2).reshape(views * emitters, 2, taps)
        out.createVariable("Data.SamplingRate", "f8", ("I",))[:] = [RATE]
        view = out.createVariable("ListenerView", "f8", ("M", "C"))
        view[:] = [[v, 0.0, 1.0] for v in VIEWS for _ in EMITTERS]
        view.Type = "spherical"
        out.createVariable("SourcePosition", "f8", ("M", "C"))[:] = [e for _ in VIEWS for e in EMITTERS]
    room = read_sofa_room(tmp_path / "srir.sofa")
    assert room.emitters == 2 and len(room.emitter) == views * emitters
    index = room.nearest(int(room.emitter[1]), -80.0)
    assert room.view[index] == pytest.approx(-90.0) and np.array_equal(room.taps[index], brirs[3, 1])
