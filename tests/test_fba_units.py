"""Live FBA units (comparisons/transport/fba_units.py) and live BBA decoding (bba_codec.LiveDecoder, split_units)."""
from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from comparisons.params import bba as bba_codec
from comparisons.params import fap_table
from comparisons.params.fba import BAPS, FAPS, decode_fba
from comparisons.transport.fba_units import (
    HEADER_BYTES,
    UNIT_OVERHEAD_BYTES,
    UnitScanner,
    assemble,
    encode_fba_units,
    find_units,
)
from media.errors import SigncastError
from media.fingerspelling import fingerspell

BAP_CHANNELS = (0, 1, 2, 30, 31, 45, 80, 181)        # root angles, some joints, a root translation
FAP_CHANNELS = (2, 3, 18, 47)                        # low-level FAPs 3, 4, 19, 48


def walk(n_frames: int, seed: int = 0, with_baps: bool = True, with_faps: bool = False):
    """(BAPs (T, 296) | None, FAPs (T, 68) | None): random walks of integer values in a few channels."""
    rng = np.random.default_rng(seed)
    baps = faps = None
    if with_baps:
        baps = np.zeros((n_frames, BAPS.count), dtype=np.int64)
        scale = np.array([3000] * 7 + [20])             # 1e-5 rad per frame for the angles, mm for the translation
        limit = np.array([300000] * 7 + [3000])
        start = rng.integers(-20000, 20000, size=len(BAP_CHANNELS)) * scale // 3000
        walked = start + np.cumsum(rng.integers(-1, 2, size=(n_frames, len(BAP_CHANNELS))) * scale
                                   * rng.integers(0, 2, size=(n_frames, 1)), axis=0)
        baps[:, BAP_CHANNELS] = np.clip(walked, -limit, limit)
    if with_faps:
        faps = np.zeros((n_frames, FAPS.count), dtype=np.int64)
        limits = fap_table.limits()[list(FAP_CHANNELS)] // 4
        faps[:, FAP_CHANNELS] = np.clip(np.cumsum(rng.integers(-40, 41, size=(n_frames, len(FAP_CHANNELS))), axis=0),
                                        -limits, limits)
    return baps, faps


def stream_of(units) -> bytes:
    return b"".join(unit.data for unit in units)


# ------------------------------------------------------------------------------------------ FBA units

@pytest.mark.parametrize("coding", ["pred", "dct"])
@pytest.mark.parametrize("with_faps", [False, True])
@pytest.mark.parametrize("refresh", [1, 7, 16, 45])
def test_units_decode_to_each_groups_own_stream_and_within_half_a_step(coding, with_faps, refresh):
    baps, faps = walk(37, seed=refresh, with_faps=with_faps)
    units = encode_fba_units(baps, 25, 4, coding, faps=faps, refresh=refresh)
    assert [(u.first_frame, u.n_frames) for u in units] == [(s, min(refresh, 37 - s)) for s in range(0, 37, refresh)]
    found, skipped = find_units(stream_of(units))
    assert skipped == 0 and [(u.first_frame, u.n_frames) for u in found] == [(u.first_frame, u.n_frames) for u in units]
    received = assemble(found, 37)
    assert received.received.all() and received.lost_units == [] and received.concealed == 0 and received.fps == 25
    own = [decode_fba(unit.data[HEADER_BYTES:]) for unit in units]
    assert np.array_equal(received.baps, np.concatenate([d.baps for d in own]))
    if with_faps:
        assert np.array_equal(received.faps, np.concatenate([d.faps for d in own])) and received.face_frames.all()
    else:
        assert received.faps is None and received.face_frames is None
    if coding == "pred":
        assert np.all(np.abs(received.baps - baps) <= BAPS.steps(4) // 2)
        if with_faps:
            assert np.all(np.abs(received.faps - faps) <= FAPS.steps(4) // 2)


def test_face_only_units_and_face_that_comes_and_goes():
    baps, faps = walk(30, with_faps=True)
    face_only = assemble(find_units(stream_of(encode_fba_units(None, 25, 4, faps=faps, refresh=8)))[0], 30)
    assert face_only.baps is None and np.all(np.abs(face_only.faps - faps) <= FAPS.steps(4) // 2)
    face_frames = np.arange(30) >= 12                    # the first unit has no face at all
    units = encode_fba_units(baps, 25, 4, faps=faps, face_frames=face_frames, refresh=8)
    received = assemble(find_units(stream_of(units))[0], 30)
    assert np.array_equal(received.face_frames, face_frames) and not received.faps[:12].any()


def test_unit_overhead_is_the_header_and_the_embedded_streams_framing():
    baps, _ = walk(32)
    data = encode_fba_units(baps, 25, 4, refresh=32)[0].data
    assert data[HEADER_BYTES:HEADER_BYTES + 5] == b"\x7f\x00\x00\x01\xba"   # stuffing, fba_object_start_code
    assert data[-8:-4] == b"\x00\x00\x01\xb1"                              # end code, then the CRC-32
    assert UNIT_OVERHEAD_BYTES == (HEADER_BYTES + 5 + 8, HEADER_BYTES + 5 + 8 + 1)


@pytest.mark.parametrize("bad", [0, 65536, -1, 2.5, True])
def test_encoder_refuses_a_refresh_period_outside_the_unit_header(bad):
    baps, _ = walk(5)
    with pytest.raises(SigncastError, match="refresh"):
        encode_fba_units(baps, 25, 4, refresh=bad)


def test_encoder_keeps_encode_fbas_errors():
    with pytest.raises(SigncastError, match="BAP values must be"):
        encode_fba_units(np.zeros((0, BAPS.count), np.int64), 25, 4)
    with pytest.raises(SigncastError):
        encode_fba_units(np.zeros((4, BAPS.count), np.int64), 25, 0)
    with pytest.raises(SigncastError, match="unknown FBA coding"):
        encode_fba_units(np.zeros((4, BAPS.count), np.int64), 25, 4, "wavelet")
    with pytest.raises(SigncastError, match="needs BAP values"):
        encode_fba_units(None, 25, 4)


def check_report(received, n_frames: int) -> None:
    """lost_units covers exactly the frames not received; concealed counts them."""
    covered = np.zeros(n_frames, dtype=bool)
    for first, n in received.lost_units:
        assert n > 0 and not covered[first:first + n].any()
        covered[first:first + n] = True
    assert np.array_equal(covered, ~received.received) and received.concealed == int(covered.sum())


@pytest.mark.parametrize("coding", ["pred", "dct"])
def test_every_single_damaged_byte_loses_at_most_the_unit_that_holds_it(coding):
    n_frames, refresh = 30, 8
    baps, faps = walk(n_frames, seed=3, with_faps=True)
    baps[:, BAP_CHANNELS[3:]] = 0                        # keep the clip small: the scan is exhaustive
    units = encode_fba_units(baps, 25, 8, coding, faps=faps, refresh=refresh)
    data = stream_of(units)
    clean = assemble(find_units(data)[0], n_frames)
    owner = np.concatenate([np.full(len(u.data), k) for k, u in enumerate(units)])
    for position in range(len(data)):
        damaged = bytearray(data)
        damaged[position] ^= 0xFF
        found, skipped = find_units(bytes(damaged))
        hit = units[owner[position]]
        assert [u.first_frame for u in found] == [u.first_frame for u in units if u is not hit], position
        assert skipped == len(hit.data)
        received = assemble(found, n_frames)
        check_report(received, n_frames)
        assert received.lost_units == [(hit.first_frame, hit.n_frames)]
        assert np.array_equal(received.baps[received.received], clean.baps[received.received])


def test_dropped_units_are_reported_and_held_or_interpolated():
    n_frames = 40
    baps, faps = walk(n_frames, seed=5, with_faps=True)
    units = encode_fba_units(baps, 25, 4, faps=faps, refresh=5)
    clean = assemble(find_units(stream_of(units))[0], n_frames)
    kept = [u for k, u in enumerate(units) if k not in (0, 3, 4, 7)]     # frames 0-4, 15-24, 35-39
    found, _ = find_units(stream_of(kept))
    hold = assemble(found, n_frames)
    assert hold.lost_units == [(0, 5), (15, 10), (35, 5)] and hold.concealed == 20
    check_report(hold, n_frames)
    assert np.array_equal(hold.baps[:5], np.repeat(clean.baps[5:6], 5, axis=0))        # none before: first after
    assert np.array_equal(hold.baps[15:25], np.repeat(clean.baps[14:15], 10, axis=0))
    assert np.array_equal(hold.faps[35:], np.repeat(clean.faps[34:35], 5, axis=0))
    assert np.array_equal(hold.baps[hold.received], clean.baps[hold.received])
    line = assemble(found, n_frames, conceal="interpolate")
    assert np.array_equal(line.baps[:5], hold.baps[:5]) and np.array_equal(line.baps[35:], hold.baps[35:])
    weights = (np.arange(15, 25) - 14) / 11
    expected = np.round(clean.baps[14] + weights[:, None] * (clean.baps[25] - clean.baps[14])).astype(np.int64)
    assert np.array_equal(line.baps[15:25], expected)
    # units that arrive twice, out of order or beyond the clip: first kept, the rest ignored
    shuffled = found[::-1] + found
    again = assemble(shuffled, 30)
    assert np.array_equal(again.baps, assemble(found, 30).baps)
    with pytest.raises(SigncastError, match="no unit of the stream arrived"):
        assemble([], n_frames)
    with pytest.raises(SigncastError, match="no unit"):
        assemble(find_units(stream_of(units[-1:]))[0], 35)       # its frames are all beyond the clip


def test_truncated_garbage_and_random_bytes_never_raise():
    baps, _ = walk(24, seed=7)
    units = encode_fba_units(baps, 25, 4, refresh=8)
    data = stream_of(units)
    ends = np.cumsum([len(u.data) for u in units])
    for cut in range(0, len(data) + 1, 3):
        found, skipped = find_units(data[:cut])
        assert len(found) == int(np.sum(ends <= cut)) and skipped == cut - sum(len(u.data) for u in units[:len(found)])
    rng = np.random.default_rng(0)
    prefix = b"\x00\x00\x01\xc4"
    for garbage in (b"", prefix, prefix * 50, rng.bytes(5000), prefix + b"\xff" * 20, data[::-1],
                    prefix + data[4:], data[:HEADER_BYTES] + rng.bytes(2000)):
        found, skipped = find_units(garbage)
        assert skipped + sum(len(units[u.first_frame // 8].data) for u in found) == len(garbage)
    found, skipped = find_units(rng.bytes(100) + data + rng.bytes(100))
    assert [u.first_frame for u in found] == [0, 8, 16] and skipped == 200


def test_scanner_fed_in_small_chunks_gives_units_as_soon_as_they_are_complete():
    baps, _ = walk(24, seed=8)
    units = encode_fba_units(baps, 25, 4, refresh=8)
    data = b"\x00\x01" + stream_of(units)
    scanner = UnitScanner()
    completed_at = []
    for end in range(0, len(data), 5):
        for unit in scanner.feed(data[end:end + 5]):
            completed_at.append((unit.first_frame, end + 5))
        assert len(scanner.buffer) <= max(len(u.data) for u in units) + 5
    assert scanner.finish() == [] and scanner.skipped == 2
    ends = np.cumsum([len(u.data) for u in units]) + 2
    assert [f for f, _ in completed_at] == [0, 8, 16]
    assert all(0 <= at - stop < 5 for (_, at), stop in zip(completed_at, ends))


@st.composite
def lossy_streams(draw):
    n_frames = draw(st.integers(1, 40))
    seed = draw(st.integers(0, 2 ** 16))
    refresh = draw(st.integers(1, 45))
    coding = draw(st.sampled_from(["pred", "dct"]))
    n_units = -(-n_frames // refresh)
    dropped = draw(st.sets(st.integers(0, n_units - 1), max_size=n_units))
    flips = draw(st.lists(st.tuples(st.floats(0, 1, exclude_max=True), st.integers(1, 255)), max_size=3))
    conceal = draw(st.sampled_from(["hold", "interpolate"]))
    return n_frames, seed, refresh, coding, dropped, flips, conceal


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(lossy_streams())
def test_lossy_streams_decode_within_bounds_and_report_every_lost_unit(case):
    n_frames, seed, refresh, coding, dropped, flips, conceal = case
    baps, _ = walk(n_frames, seed=seed)
    units = encode_fba_units(baps, 25, 4, coding, refresh=refresh)
    sent = [u for k, u in enumerate(units) if k not in dropped]
    data = bytearray(stream_of(sent))
    owner = np.concatenate([np.full(len(u.data), k) for k, u in enumerate(sent)] or [np.zeros(0, int)])
    clean = bytes(data)
    for where, mask in flips:
        if data:
            data[int(where * len(data))] ^= mask
    changed = np.flatnonzero(np.frombuffer(bytes(data), np.uint8) != np.frombuffer(clean, np.uint8))
    damaged_units = set(owner[changed].tolist())            # flips at one byte can cancel
    found, skipped = find_units(bytes(data))
    assert 0 <= skipped <= len(data)
    intact = [u for k, u in enumerate(sent) if k not in damaged_units]
    assert [u.first_frame for u in found] == [u.first_frame for u in intact]
    if not found:
        with pytest.raises(SigncastError):
            assemble(found, n_frames, conceal)
        return
    received = assemble(found, n_frames, conceal)
    assert received.baps.shape == (n_frames, BAPS.count) and received.received.shape == (n_frames,)
    check_report(received, n_frames)
    expected = np.zeros(n_frames, dtype=bool)
    for u in intact:
        expected[u.first_frame:u.first_frame + u.n_frames] = True
    assert np.array_equal(received.received, expected)
    decoded = received.baps[received.received]
    low, high = decoded.min(axis=0), decoded.max(axis=0)
    assert np.all((received.baps >= low) & (received.baps <= high))
    if coding == "pred":
        assert np.all(np.abs(decoded - baps[received.received]) <= BAPS.steps(4) // 2)


# ------------------------------------------------------------------------------------------ BBA live

def bba_stream(coding: str, **extra) -> bytes:
    motion = fingerspell("ase", "HI", 25)
    return bba_codec.write_stream(bba_codec.motion_to_stream(motion, 4, coding, **extra))


def live_decode(pieces: list[bytes], header: bytes | None = None):
    decoder = bba_codec.LiveDecoder(header)
    frames = []
    for piece in pieces:
        frames += decoder.feed(piece)
    decoder.finish()
    return decoder, frames


@pytest.mark.parametrize("coding, extra", [("pred", {}), ("dct", {}), ("pred", {"keyframes": True}),
                                           ("pred", {"header_period": 2})])
def test_split_units_round_trips_and_live_decoding_matches_read_stream(coding, extra):
    data = bba_stream(coding, **extra)
    pieces = bba_codec.split_units(data)
    assert b"".join(pieces) == data
    assert sum(p.startswith(b"\x00\x00\x01\xd1") for p in pieces) == data.count(b"\x00\x00\x01\xd1")
    decoder, frames = live_decode(pieces[1:], pieces[0])
    stream, lost = bba_codec.read_stream(data)
    assert [f for _, f in frames] == stream.frames and decoder.lost == lost == [] and decoder.dropped == 0
    numbers = bba_codec.display_numbers(stream.frames)
    assert [n for n, _ in frames] == numbers.tolist()


@pytest.mark.parametrize("coding", ["pred", "dct"])
def test_live_decoder_drops_damaged_and_lost_units_as_the_resilient_reader_does(coding):
    data = bba_stream(coding, intra_period=4)
    pieces = bba_codec.split_units(data)
    units = [k for k, p in enumerate(pieces) if p.startswith(b"\x00\x00\x01\xd1")]
    rng = np.random.default_rng(1)
    all_lost = []
    for trial in range(6):
        damaged = list(pieces)
        for k in rng.choice(units, size=2, replace=False):
            piece = bytearray(damaged[k])
            piece[int(rng.integers(4, len(piece)))] ^= int(rng.integers(1, 256))
            damaged[k] = bytes(piece)
        if trial % 2:
            damaged[units[-1]] = b""                                    # the last unit never arrives
        whole = b"".join(damaged)
        stream, lost = bba_codec.read_stream(whole, resilient=True)
        decoder, frames = live_decode(damaged[1:], damaged[0])
        assert decoder.lost == lost
        placed = dict(frames)
        assert set(placed) == set(range(len(stream.frames))) - set(lost)
        assert all(stream.frames[n] == frame for n, frame in placed.items())
        all_lost += lost
    assert all_lost                                                     # the damage did cost frames


def test_live_decoder_waits_for_a_header_copy_when_the_header_is_lost():
    data = bba_stream("pred", header_period=1, intra_period=8)
    pieces = bba_codec.split_units(data)
    decoder, frames = live_decode(pieces[1:])                          # the first header never arrives
    stream, _ = bba_codec.read_stream(data)
    assert frames and [n for n, _ in frames] == list(range(8, len(stream.frames)))
    assert decoder.lost == list(range(8)) and all(stream.frames[n] == f for n, f in frames)
    with pytest.raises(SigncastError):
        bba_codec.LiveDecoder(b"\x00\x00\x01\xd0" + b"\x55" * 20)
    garbage = bba_codec.LiveDecoder(pieces[0])
    assert garbage.feed(b"") == [] and garbage.feed(np.random.default_rng(2).bytes(300)) == []
    assert garbage.dropped == 2
