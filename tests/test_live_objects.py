"""Live video objects: ObjectSource -> RTP packetisers -> depacketisers -> ObjectSink, without sockets, on a real
rendered fingerspelling (ASL "AB", 16 frames at 128x96) and its part labels."""
from __future__ import annotations

import numpy as np
import pytest

from comparisons.video import quality as image_quality
from comparisons.transport import rtp
from comparisons.transport import shape_units
from comparisons.video import objects as video_objects
from comparisons.transport.video import LiveDecoder
from media.errors import SigncastError
from pipeline.live.objects import (
    TEXTURE_GOP,
    CausalPadder,
    ObjectSink,
    ObjectSource,
    object_streams,
)
from pipeline.live.session import SessionDescription, packetizer_for

WIDTH, HEIGHT, N_FRAMES, FPS, Q = 128, 96, 16, 25.0, 4
DEPACKETIZERS = {"units": rtp.depacketize_parameters, "h264": rtp.depacketize_h264, "mp4v": rtp.depacketize_mp4v}


@pytest.fixture(scope="module")
def clip(avatar):
    """(frames (T, H, W, 3) uint8, labels (T, H, W) uint8) of ASL 'AB' rendered at 128x96."""
    from media.fingerspelling import fingerspell
    from media.render import AvatarRenderer, RenderSettings
    motion = fingerspell("ase", "AB").frames(0, N_FRAMES)
    rendered = list(AvatarRenderer(avatar, RenderSettings(width=WIDTH, height=HEIGHT)).frames(motion))
    return np.stack([rgb for rgb, _ in rendered]), np.stack([labels for _, labels in rendered])


def description_of(source: ObjectSource, solution: str, codec: str) -> SessionDescription:
    return SessionDescription(solution, codec, "objects", Q, FPS, N_FRAMES, WIDTH, HEIGHT,
                              streams=[{"name": name, "payload": payload} for name, payload in source.streams])


def deliver(source: ObjectSource, sink: ObjectSink, drop=lambda name, frame: False):
    """Send a whole session through real packetisers and depacketisers (one per stream, as session.send does).
    drop(stream name, frame) loses an access unit entirely. Returns (ready_at (T,) int: the capture during which
    each frame became ready (-1: never), {stream name: [(frame, bytes)]} of what was sent)."""
    packetizers = [packetizer_for(payload, seed=k) for k, (_, payload) in enumerate(source.streams)]
    ready_at = np.full(N_FRAMES, -1)
    sent: dict[str, list] = {name: [] for name, _ in source.streams}

    def emit(units, now: int) -> None:
        for unit in units:
            name, payload = source.streams[unit.stream]
            packetizer = packetizers[unit.stream]
            first = packetizer.sequence
            timestamp = rtp.timestamp_of(unit.frame, FPS)
            packets = (packetizer.packetize_units(unit.data, timestamp) if payload == "units"
                       else packetizer.packetize(unit.data, timestamp))
            sent[name].append((unit.frame, unit.data))
            if drop(name, unit.frame):
                continue
            for index in sink.receive(unit.frame, DEPACKETIZERS[payload](packets, first), unit.stream):
                assert ready_at[index] == -1
                ready_at[index] = now

    for index in range(N_FRAMES):
        emit(source.capture(index), index)
    emit(source.finish(), N_FRAMES)
    return ready_at, sent


def decode_objects(sent: dict, codec: str, names) -> tuple[dict, dict]:
    """Each object's texture and shape decoded on its own, without loss: ({name: (T, H, W, 3)}, {name: (T, H, W)})."""
    textures, masks = {}, {}
    for name in names:
        decoder = LiveDecoder(codec, WIDTH, HEIGHT)
        pictures = dict(picture for frame, data in sent[f"{name}/texture"] for picture in decoder.decode(data, frame))
        pictures.update(decoder.flush())
        textures[name] = np.stack([pictures[t] for t in range(N_FRAMES)])
        found = [unit for _, data in sent[f"{name}/shape"] for unit in shape_units.find_shape_units(data[0])[0]]
        masks[name] = shape_units.assemble_shape(found, N_FRAMES, HEIGHT, WIDTH)[0]
    return textures, masks


def composed(textures: list[np.ndarray], masks: list[np.ndarray | None]) -> np.ndarray:
    """One frame composed as video_objects.compose does: black, then each object inside its mask."""
    picture = np.zeros((HEIGHT, WIDTH, 3), np.uint8)
    for texture, mask in zip(textures, masks):
        if mask is not None:
            picture[mask] = texture[mask]
    return picture


def run(clip, solution: str, codec: str = "mpeg4", shape_gop: int = 1, drop=lambda name, frame: False):
    frames, labels = clip
    source = ObjectSource(solution, frames, labels, FPS, codec, Q, shape_gop=shape_gop)
    sink = ObjectSink(description_of(source, solution, codec))
    ready_at, sent = deliver(source, sink, drop)
    pending = sum(len(s.textures) + len(s.concealed) + len(s.masks) for s in sink.states)
    shown, received = sink.finish()
    return shown, received, ready_at, sent, sink, pending


@pytest.fixture(scope="module")
def clean(clip):
    """The lossless NSV3O mpeg4 session and its objects decoded separately."""
    shown, received, ready_at, sent, _, pending = run(clip, "NSV3O")
    textures, masks = decode_objects(sent, "mpeg4", video_objects.SOLUTION_OBJECTS["NSV3O"])
    return shown, received, ready_at, textures, masks, pending


def test_causal_padder_pads_frame_by_frame_as_pad_object_pads_the_whole_clip(clip):
    frames, labels = clip
    masks = video_objects.object_masks_for("NSV3O", labels)["right_hand"]
    padder = CausalPadder()
    live = np.stack([padder.pad(frames[t], masks[t], t % TEXTURE_GOP == 0) for t in range(N_FRAMES)])
    assert np.array_equal(live, video_objects.pad_object(frames, masks, gop=TEXTURE_GOP))
    assert np.array_equal(live[masks], frames[masks])


@pytest.mark.parametrize("solution", ["SSV", "NSV3O"])
def test_lossless_session_composes_every_frame_like_the_offline_composition(clip, solution):
    frames, labels = clip
    shown, received, ready_at, sent, sink, pending = run(clip, solution)
    names = video_objects.SOLUTION_OBJECTS[solution]
    textures, masks = decode_objects(sent, "mpeg4", names)
    truth = video_objects.object_masks_for(solution, labels)
    assert received.all() and pending == 0
    assert np.array_equal(ready_at, np.arange(N_FRAMES))            # shape_gop 1: each frame ready at its capture
    for name in names:
        assert np.array_equal(masks[name], truth[name])            # the shape is lossless
    for t in range(N_FRAMES):
        assert np.array_equal(shown[t], composed([textures[n][t] for n in names], [masks[n][t] for n in names]))
    skin = np.any([truth[n] for n in names], axis=0)
    assert image_quality.psnr(frames, shown, skin) > 28.0
    assert not shown[~skin].any()                                   # black outside every object
    assert all(sink.stats[n]["shape_units"] == N_FRAMES and sink.stats[n]["held_shape_frames"] == 0 for n in names)


def test_shape_units_of_four_frames_delay_frames_to_the_unit_end_and_change_nothing_else(clip, clean):
    shown, received, ready_at, _, sink, _ = run(clip, "NSV3O", shape_gop=4)
    assert received.all()
    assert np.array_equal(ready_at, np.minimum(np.arange(N_FRAMES) // 4 * 4 + 3, N_FRAMES - 1))
    assert np.array_equal(shown, clean[0])
    assert sink.stats["head"]["shape_units"] == N_FRAMES // 4


def test_lost_shape_unit_holds_the_previous_mask_and_the_next_unit_recovers(clip, clean):
    clean_shown, _, _, textures, masks, _ = clean
    shown, received, _, _, sink, _ = run(clip, "NSV3O", drop=lambda name, frame: name == "right_hand/shape"
                                         and frame == 5)
    assert shown.shape == (N_FRAMES, HEIGHT, WIDTH, 3)
    assert np.flatnonzero(~received).tolist() == [5]
    names = ("head", "left_hand", "right_hand")
    held = [masks["head"][5], masks["left_hand"][5], masks["right_hand"][4]]
    assert not np.array_equal(masks["right_hand"][4], masks["right_hand"][5])
    assert np.array_equal(shown[5], composed([textures[n][5] for n in names], held))
    assert np.array_equal(np.delete(shown, 5, axis=0), np.delete(clean_shown, 5, axis=0))
    assert sink.stats["right_hand"]["held_shape_frames"] == 1 and sink.stats["head"]["held_shape_frames"] == 0


def test_lost_first_shape_unit_leaves_the_object_transparent(clip, clean):
    _, _, _, textures, masks, _ = clean
    shown, received, _, _, _, _ = run(clip, "NSV3O", drop=lambda name, frame: name == "head/shape" and frame == 0)
    assert np.flatnonzero(~received).tolist() == [0]
    names = ("left_hand", "right_hand")
    assert np.array_equal(shown[0], composed([textures[n][0] for n in names], [masks[n][0] for n in names]))


def test_lost_texture_access_unit_is_concealed_and_the_next_keyframe_recovers(clip, clean):
    clean_shown, _, _, textures, masks, _ = clean
    shown, received, ready_at, _, sink, _ = run(clip, "NSV3O", drop=lambda name, frame: name == "head/texture"
                                                and frame == 3)
    assert not received[3] and ready_at[3] == -1 and received[12:].all()
    names = ("head", "left_hand", "right_hand")
    held = [textures["head"][2], textures["left_hand"][3], textures["right_hand"][3]]   # the decoder holds frame 2
    assert np.array_equal(shown[3], composed(held, [masks[n][3] for n in names]))
    assert np.array_equal(shown[12:], clean_shown[12:])             # texture keyframe at 12 (GOP 12)
    assert np.array_equal(shown[:3], clean_shown[:3])
    head = sink.stats["head"]["texture"]
    assert head["lost"] == 1 and head["concealed"] == 1 and sink.stats["left_hand"]["texture"]["lost"] == 0


def test_nsv2o_with_libx264_sends_the_signer_only(clip):
    frames, labels = clip
    shown, received, _, sent, _, _ = run(clip, "NSV2O", codec="libx264")
    signer = video_objects.object_masks_for("NSV2O", labels)["signer"]
    assert received.all() and list(sent) == ["signer/texture", "signer/shape"]
    assert not shown[~signer].any()
    assert image_quality.psnr(frames, shown, signer) > 28.0


def test_clothes_are_coded_at_the_offline_clothes_quantiser(clip):
    frames, labels = clip
    source = ObjectSource("NSV3O+C", frames, labels, FPS, "mpeg4", Q)
    assert [name for name, _ in source.streams][-2:] == ["clothes/texture", "clothes/shape"]
    clothes = source.encoders["clothes"]._context
    head = source.encoders["head"]._context
    assert (clothes.qmin, head.qmin) == (video_objects.CLOTHES_Q, Q)


def test_bad_parameters_and_descriptions_raise_signcast_errors(clip):
    frames, labels = clip
    with pytest.raises(SigncastError):
        ObjectSource("NSV", frames, labels, FPS, "mpeg4", Q)
    with pytest.raises(SigncastError):
        ObjectSource("SSV", frames, labels[:, :-1], FPS, "mpeg4", Q)
    with pytest.raises(SigncastError):
        ObjectSource("SSV", frames, labels, FPS, "mpeg4", Q, shape_gop=0)
    with pytest.raises(SigncastError):
        object_streams("SSV", "vp9")
    swapped = [{"name": name, "payload": payload} for name, payload in object_streams("SSV", "mpeg4")][::-1]
    with pytest.raises(SigncastError):
        ObjectSink(SessionDescription("SSV", "mpeg4", "objects", Q, FPS, N_FRAMES, WIDTH, HEIGHT, streams=swapped))


def test_damaged_and_foreign_bytes_never_raise(clip):
    frames, labels = clip
    source = ObjectSource("SSV", frames, labels, FPS, "mpeg4", Q)
    sink = ObjectSink(description_of(source, "SSV", "mpeg4"))
    rng = np.random.default_rng(1)
    junk = rtp.Depacketized(units=[rtp.Unit(0, rng.integers(0, 256, 300, dtype=np.uint8).tobytes(), damaged=True)])
    for stream in range(len(source.streams) + 1):
        assert sink.receive(2, junk, stream) == []
    assert sink.receive(N_FRAMES + 5, junk, 0) == []
    shown, received = sink.finish()
    assert shown.shape == (N_FRAMES, HEIGHT, WIDTH, 3) and not received.any()
    assert sink.stats["unknown_streams"] == 1
