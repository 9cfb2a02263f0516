"""Live video (frame-by-frame PyAV coding, FFmpeg concealment) and shape units that survive loss."""
from __future__ import annotations

import numpy as np
import pytest

from comparisons.transport.video import LiveDecoder, LiveEncoder
from comparisons.video.shape import encode_shape
from comparisons.transport.shape_units import (
    HEADER_SIZE,
    START_CODE,
    assemble_shape,
    encode_shape_units,
    find_shape_units,
)
from comparisons.video.codecs import decode_video
from media.errors import SigncastError

WIDTH, HEIGHT, N_FRAMES, GOP = 64, 48, 25, 12
Q = {"mpeg4": 3, "libx264": 20}
THRESHOLD_DB = 25.0


def moving_pattern(n: int = N_FRAMES) -> np.ndarray:
    """(n, 48, 64, 3) uint8: drifting sinusoids plus a disc crossing the frame."""
    y, x = np.mgrid[:HEIGHT, :WIDTH].astype(float)
    frames = []
    for t in range(n):
        red = 128 + 100 * np.sin(2 * np.pi * (x + 2 * t) / 32)
        green = 128 + 100 * np.cos(2 * np.pi * (y - t) / 24)
        blue = np.where((x - 10 - 1.5 * t) ** 2 + (y - 24) ** 2 < 100, 230.0, 30.0)
        frames.append(np.clip(np.stack([red, green, blue], -1), 0, 255).astype(np.uint8))
    return np.stack(frames)


def psnr(a: np.ndarray, b: np.ndarray) -> float:
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return 99.0 if mse == 0 else float(10 * np.log10(255.0 ** 2 / mse))


SOURCE = moving_pattern()


def live_packets(codec: str, b_frames: int = 0):
    encoder = LiveEncoder(codec, WIDTH, HEIGHT, 25.0, Q[codec], gop=GOP, b_frames=b_frames)
    packets = []
    for index, frame in enumerate(SOURCE):
        packets += encoder.encode(frame, index)
    return packets + encoder.flush(), encoder


def receive(codec: str, packets, alter=lambda packet: (packet.data, False)):
    """Decode (index, data, damaged) through a LiveDecoder; returns ({index: picture}, statuses in order, decoder)."""
    decoder = LiveDecoder(codec, WIDTH, HEIGHT)
    shown, statuses, order = {}, [], []
    for packet in packets:
        data, damaged = alter(packet)
        for index, picture in decoder.decode(data, packet.index, damaged):
            shown[index] = picture
            order.append(index)
        statuses += decoder.last_status
    for index, picture in decoder.flush():
        shown[index] = picture
        order.append(index)
    statuses += decoder.last_status
    assert order == sorted(order) and len(order) == len(set(order))
    assert all(picture.shape == (HEIGHT, WIDTH, 3) and picture.dtype == np.uint8 for picture in shown.values())
    return shown, dict(zip(order, statuses)), decoder


@pytest.mark.parametrize("codec", ["mpeg4", "libx264"])
def test_live_stream_without_loss_shows_every_frame_and_is_a_real_elementary_stream(codec):
    packets, encoder = live_packets(codec)
    assert [p.index for p in packets] == list(range(N_FRAMES))          # no B-frames: one packet per frame, in order
    assert encoder.max_delay == 0
    assert [p.index for p in packets if p.keyframe] == [0, 12, 24]
    shown, statuses, decoder = receive(codec, packets)
    assert sorted(shown) == list(range(N_FRAMES)) and set(statuses.values()) == {"ok"}
    assert min(psnr(shown[i], SOURCE[i]) for i in range(N_FRAMES)) > THRESHOLD_DB
    assert decoder.stats.decoded == N_FRAMES and decoder.stats.concealed == decoder.stats.damaged == 0
    frames, types = decode_video(b"".join(p.data for p in packets), codec)
    assert len(frames) == N_FRAMES and types[0] == types[12] == "I"
    assert min(psnr(frames[i], SOURCE[i]) for i in range(N_FRAMES)) > THRESHOLD_DB


@pytest.mark.parametrize("codec,header", [("mpeg4", b"\x00\x00\x01\xb0"), ("libx264", b"\x00\x00\x00\x01\x67")])
def test_every_keyframe_packet_carries_the_configuration_and_starts_decoding(codec, header):
    packets, _ = live_packets(codec)
    assert all(p.data.startswith(header) for p in packets if p.keyframe)
    assert not any(header in p.data for p in packets if not p.keyframe)
    shown, statuses, _ = receive(codec, packets[12:])
    assert sorted(shown) == list(range(12, N_FRAMES)) and statuses[12] == "ok"
    assert min(psnr(shown[i], SOURCE[i]) for i in range(12, N_FRAMES)) > THRESHOLD_DB


@pytest.mark.parametrize("codec", ["mpeg4", "libx264"])
def test_b_frames_delay_the_encoder_and_the_decoder_still_shows_every_frame_in_order(codec):
    packets, encoder = live_packets(codec, b_frames=2)
    assert encoder.max_delay >= 2 and [p.index for p in packets] != list(range(N_FRAMES))
    shown, statuses, _ = receive(codec, packets)
    assert sorted(shown) == list(range(N_FRAMES)) and set(statuses.values()) == {"ok"}
    assert min(psnr(shown[i], SOURCE[i]) for i in range(N_FRAMES)) > THRESHOLD_DB


def _flip_middle(data: bytes) -> bytes:
    damaged = bytearray(data)
    middle = len(damaged) // 2
    for k in range(middle, middle + 8):
        damaged[k] ^= 0xA5
    return bytes(damaged)


# case: (frame hit, what happens to its packet)
CASES = {
    "lose_p_frame": (5, lambda data: None),
    "lose_keyframe": (12, lambda data: None),
    "flip_bytes": (5, _flip_middle),
    "truncate": (5, lambda data: data[:len(data) // 3]),
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("codec", ["mpeg4", "libx264"])
def test_loss_and_damage_are_concealed_and_the_next_keyframe_cleans_the_picture(codec, case):
    hit, change = CASES[case]
    # FFmpeg's H.264 decoder does not notice bytes flipped inside a CABAC slice (it decodes garbage "cleanly");
    # there the transport says the payload is damaged. MPEG-4 Part 2 and truncation are detected by FFmpeg.
    hint = codec == "libx264" and case == "flip_bytes"
    packets, _ = live_packets(codec)
    shown, statuses, decoder = receive(codec, packets,
                                       lambda p: (change(p.data), hint) if p.index == hit else (p.data, False))
    assert sorted(shown) == list(range(N_FRAMES))
    recovery = (hit // GOP + 1) * GOP                                    # the next keyframe
    assert all(statuses[i] != "ok" for i in range(hit, recovery))
    assert all(statuses[i] == "ok" for i in range(hit)) and all(statuses[i] == "ok" for i in range(recovery, N_FRAMES))
    assert min(psnr(shown[i], SOURCE[i]) for i in range(recovery, N_FRAMES)) > THRESHOLD_DB
    stats = decoder.stats
    assert stats.decoded + stats.concealed == N_FRAMES
    assert stats.concealed + stats.damaged == recovery - hit
    if case.startswith("lose"):
        assert stats.lost == 1 and statuses[hit] == "concealed" and np.array_equal(shown[hit], shown[hit - 1])
    else:
        assert stats.lost == 0 and stats.damaged >= 1
        assert psnr(shown[hit], SOURCE[hit]) < THRESHOLD_DB                # the damage was real


@pytest.mark.parametrize("codec", ["mpeg4", "libx264"])
def test_decoder_never_raises_on_random_bytes_or_flipped_packets(codec):
    rng = np.random.default_rng(7)
    packets, _ = live_packets(codec)
    decoder = LiveDecoder(codec, WIDTH, HEIGHT)
    prefixes = [b"", packets[0].data[:16], packets[1].data[:8]]            # reach past the start-code parsers
    shown = []
    for index in range(200):
        junk = prefixes[index % 3] + rng.integers(0, 256, int(rng.integers(0, 300)), dtype=np.uint8).tobytes()
        shown += decoder.decode(junk, index)
    for round_ in range(4):
        for packet in packets:
            data = bytearray(packet.data)
            for position in rng.integers(0, len(data), int(rng.integers(1, 6))):
                data[position] = int(rng.integers(0, 256))
            shown += decoder.decode(bytes(data), 200 + round_ * N_FRAMES + packet.index)
    shown += decoder.flush()
    assert [index for index, _ in shown] == list(range(200 + 4 * N_FRAMES))
    assert all(picture.shape == (HEIGHT, WIDTH, 3) for _, picture in shown)
    stats = decoder.stats
    assert stats.decoded + stats.concealed == 200 + 4 * N_FRAMES and stats.concealed > 0


def test_live_encoder_rejects_bad_settings_and_frames_with_one_error():
    with pytest.raises(SigncastError, match="quantiser"):
        LiveEncoder("mpeg4", WIDTH, HEIGHT, 25.0, 40)
    with pytest.raises(SigncastError, match="even"):
        LiveEncoder("libx264", 63, HEIGHT, 25.0, 20)
    with pytest.raises(SigncastError, match="unknown live codec"):
        LiveDecoder("libsvtav1", WIDTH, HEIGHT)
    encoder = LiveEncoder("mpeg4", WIDTH, HEIGHT, 25.0, 5)
    with pytest.raises(SigncastError, match="uint8"):
        encoder.encode(SOURCE[0][:-2], 0)
    encoder.encode(SOURCE[0], 3)
    with pytest.raises(SigncastError, match="does not follow"):
        encoder.encode(SOURCE[1], 3)


# ------------------------------------------------------------------------------------------------------
# shape units

def disc_masks(n: int, size: int = 32) -> np.ndarray:
    """(n, size, size) bool: a disc moving right and growing."""
    y, x = np.mgrid[:size, :size]
    return np.stack([(x - 8 - 2 * t) ** 2 + (y - 15) ** 2 < (5 + t) ** 2 for t in range(n)])


def test_shape_units_round_trip_and_each_unit_starts_with_its_own_header():
    masks = disc_masks(10)
    units = encode_shape_units(masks, gop=4)
    assert [(u.first_frame, u.n_frames) for u in units] == [(0, 4), (4, 4), (8, 2)]
    assert all(u.data.startswith(START_CODE) for u in units)
    assert len(units[0].data) == HEADER_SIZE + len(encode_shape(masks[:4], gop=4)[0])
    found, skipped = find_shape_units(b"".join(u.data for u in units))
    assert skipped == 0 and [first for first, _ in found] == [0, 4, 8]
    assembled, received, concealed = assemble_shape(found, 10, 32, 32)
    assert np.array_equal(assembled, masks) and received.all() and concealed == 0


def test_a_lost_shape_unit_holds_the_last_received_mask_and_a_missing_first_unit_hides_the_object():
    masks = disc_masks(10)
    units = encode_shape_units(masks, gop=4)
    found, _ = find_shape_units(units[0].data + units[2].data)
    assembled, received, concealed = assemble_shape(found, 10, 32, 32)
    assert received.tolist() == [True] * 4 + [False] * 4 + [True] * 2 and concealed == 4
    assert all(np.array_equal(assembled[t], masks[3]) for t in range(4, 8))
    assert np.array_equal(assembled[8:], masks[8:]) and not np.array_equal(assembled[4:8], masks[4:8])
    found, _ = find_shape_units(units[1].data + units[2].data)
    assembled, received, concealed = assemble_shape(found, 10, 32, 32)
    assert not assembled[:4].any() and received.tolist() == [False] * 4 + [True] * 6 and concealed == 4


def test_every_single_byte_damage_loses_only_the_unit_it_hits():
    masks = disc_masks(6)
    units = encode_shape_units(masks, gop=2)
    data = b"".join(u.data for u in units)
    starts = np.cumsum([0] + [len(u.data) for u in units])
    for position in range(len(data)):
        for value in (data[position] ^ 0xFF, data[position] ^ 0x01):
            damaged = data[:position] + bytes([value]) + data[position + 1:]
            hit = int(np.searchsorted(starts, position, side="right")) - 1
            found, skipped = find_shape_units(damaged)
            assert [first for first, _ in found] == [u.first_frame for k, u in enumerate(units) if k != hit]
            assert skipped == len(units[hit].data)
            assembled, received, _ = assemble_shape(found, 6, 32, 32)
            assert received.tolist() == [not hit * 2 <= t < hit * 2 + 2 for t in range(6)]
            assert np.array_equal(assembled[received], masks[received])


def test_find_shape_units_never_raises_on_random_bytes_and_resyncs_after_junk():
    rng = np.random.default_rng(3)
    units = encode_shape_units(disc_masks(4), gop=2)
    for _ in range(200):
        junk = rng.integers(0, 256, int(rng.integers(0, 200)), dtype=np.uint8).tobytes()
        find_shape_units(junk + START_CODE + junk[:HEADER_SIZE])
    junk = START_CODE + rng.integers(0, 256, 50, dtype=np.uint8).tobytes()
    found, skipped = find_shape_units(junk + units[0].data + junk + units[1].data[:-1] + units[1].data)
    assert [first for first, _ in found] == [0, 2] and skipped == 2 * len(junk) + len(units[1].data) - 1


def test_shape_units_reject_bad_parameters():
    with pytest.raises(SigncastError, match="GOP"):
        encode_shape_units(disc_masks(3), gop=0)
    with pytest.raises(SigncastError, match="cannot assemble"):
        assemble_shape([], 3, 0, 32)
