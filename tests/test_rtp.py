"""RTP packetisation: header, sequence wrap, and the H.264 / MP4V-ES / parameter payload formats on real streams."""
from __future__ import annotations

import random
import struct

import av
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from comparisons.transport import rtp
from comparisons.transport.loss import Bernoulli
from comparisons.transport.rtp import (
    H264Packetizer,
    Mp4vPacketizer,
    ParameterPacketizer,
    RtpPacket,
    access_units,
    depacketize_h264,
    depacketize_mp4v,
    depacketize_parameters,
    h264_nal_units,
    timestamp_of,
    unwrap_sequences,
    wire_bits,
)
from comparisons.video.codecs import encode_video, padded_packet
from media.errors import SigncastError

FPS = 25.0


def moving_pattern(n_frames: int = 12, height: int = 96, width: int = 128) -> np.ndarray:
    """(T, H, W, 3) uint8: a textured gradient and a bright square that move every frame."""
    yy, xx = np.mgrid[0:height, 0:width]
    frames = []
    for t in range(n_frames):
        image = np.stack([(xx * 3 + t * 7) % 256, (yy * 5 + t * 3) % 256, ((xx ^ yy) * 2 + t * 11) % 256], -1)
        image[20 + t:50 + t, 10 + 4 * t:40 + 4 * t] = 250
        frames.append(image.astype(np.uint8))
    return np.stack(frames)


@pytest.fixture(scope="module")
def streams() -> dict[str, list[bytes]]:
    frames = moving_pattern()
    return {codec: access_units(encode_video(frames, FPS, codec, q), codec)
            for codec, q in (("libx264", 34), ("mpeg4", 6))}


def decode_access_units(units: list[bytes], codec: str) -> tuple[int, int]:
    """(frames, rejected access units) when PyAV decodes the rebuilt access units in order, as a concealing
    receiver does: an access unit FFmpeg rejects as invalid data is skipped, and decoding goes on."""
    context = av.CodecContext.create("h264" if codec == "libx264" else codec, "r")
    n_frames = rejected = 0
    for unit in units:
        try:
            n_frames += len(context.decode(padded_packet(unit)))
        except av.error.InvalidDataError:
            rejected += 1
    return n_frames + len(context.decode(None)), rejected


def send(packetizer, units: list[bytes]) -> tuple[list[list[RtpPacket]], list[int]]:
    timestamps = [timestamp_of(i, FPS, 4_294_900_000) for i in range(len(units))]   # wraps mid-stream
    return [packetizer.packetize(unit, ts) for unit, ts in zip(units, timestamps)], timestamps


def shuffled_with_duplicates(packets: list[RtpPacket], seed: int) -> list[RtpPacket]:
    rng = random.Random(seed)
    arrived = packets + rng.sample(packets, len(packets) // 5)
    rng.shuffle(arrived)
    return arrived


# ------------------------------------------------------------------------------------------------ header


@given(st.integers(0, 127), st.integers(0, 65535), st.integers(0, 2**32 - 1), st.integers(0, 2**32 - 1),
       st.booleans(), st.binary(max_size=64))
def test_rtp_header_round_trips(payload_type, sequence, timestamp, ssrc, marker, payload):
    packet = RtpPacket(payload_type, sequence, timestamp, ssrc, marker, payload)
    wire = packet.to_bytes()
    assert len(wire) == 12 + len(payload)
    assert wire[0] >> 6 == 2
    assert RtpPacket.parse(wire) == packet


def test_rtp_parse_skips_csrc_extension_and_padding():
    csrcs = struct.pack("!II", 11, 22)
    extension = struct.pack("!HH", 0xBEDE, 1) + b"\x01\x02\x03\x04"
    padding = b"\x00\x00\x03"
    first = 0x80 | 0x20 | 0x10 | 2
    wire = struct.pack("!BBHII", first, 0x80 | 96, 7, 900, 5) + csrcs + extension + b"payload" + padding
    packet = RtpPacket.parse(wire)
    assert (packet.payload, packet.marker, packet.sequence, packet.timestamp, packet.ssrc) == (b"payload", True, 7,
                                                                                               900, 5)


@pytest.mark.parametrize("wire, message", [
    (b"\x80\x60\x00", "too short"),
    (struct.pack("!BBHII", 0x40, 96, 1, 2, 3), "version"),
    (struct.pack("!BBHII", 0x83, 96, 1, 2, 3) + b"\x00" * 8, "CSRC"),
    (struct.pack("!BBHII", 0x90, 96, 1, 2, 3) + struct.pack("!HH", 0, 9) + b"\x00" * 8, "extension"),
    (struct.pack("!BBHII", 0xA0, 96, 1, 2, 3) + b"ab\x09", "padding"),
    (struct.pack("!BBHII", 0xA0, 96, 1, 2, 3) + b"ab\x00", "padding"),
])
def test_rtp_parse_rejects_malformed_headers(wire, message):
    with pytest.raises(SigncastError, match=message):
        RtpPacket.parse(wire)


@given(st.binary(max_size=80))
def test_rtp_parse_raises_only_signcast_errors(wire):
    try:
        packet = RtpPacket.parse(wire)
    except SigncastError:
        return
    assert len(packet.payload) <= len(wire) - 12


def test_wire_bits_count_ip_udp_and_rtp_headers():
    packets = [RtpPacket(96, 1, 0, 1, False, b"x" * 100), RtpPacket(96, 2, 0, 1, True, b"")]
    assert rtp.HEADER_OVERHEAD == 40
    assert wire_bits(packets) == (100 + 40) * 8 + 40 * 8
    assert wire_bits(p.to_bytes() for p in packets) == wire_bits(packets)


def test_timestamps_use_90khz_clock_and_wrap():
    assert timestamp_of(25, 25.0) == 90_000
    assert timestamp_of(1, 30000 / 1001, 0) == 3003
    assert timestamp_of(1, 25.0, 2**32 - 1000) == 2600
    with pytest.raises(SigncastError):
        timestamp_of(1, 0.0)


def test_unwrap_sequences_across_wrap_with_reorder_and_duplicates():
    assert unwrap_sequences([65534, 65535, 0, 1]) == [65534, 65535, 65536, 65537]
    assert unwrap_sequences([65535, 1, 0, 1, 65534, 2]) == [65535, 65537, 65536, 65537, 65534, 65538]
    assert unwrap_sequences([0, 65535]) == [0, -1]
    long_run = [(40_000 + i) % 65536 for i in range(200_000)]
    assert unwrap_sequences(long_run) == list(range(40_000, 240_000))


def test_packetizer_rejects_bad_mtu():
    with pytest.raises(SigncastError, match="mtu"):
        H264Packetizer(mtu=4)


# ------------------------------------------------------------------------------------------------ H.264


def test_h264_nal_units_split_three_and_four_byte_start_codes():
    data = b"\x00\x00\x00\x01\x67abc\x00\x00\x01\x68de\x00\x00\x00\x00\x01\x65fgh"
    assert h264_nal_units(data) == [b"\x67abc", b"\x68de", b"\x65fgh"]
    with pytest.raises(SigncastError):
        h264_nal_units(b"\x12\x00\x00\x01\x65")


def test_h264_packets_use_stap_a_single_and_fu_a_and_round_trip_exactly(streams):
    units = streams["libx264"]
    packetizer = H264Packetizer(mtu=300, seed=3)
    per_unit, timestamps = send(packetizer, units)
    packets = [p for group in per_unit for p in group]
    kinds = {p.payload[0] & 0x1F for p in packets}
    assert {24, 28} <= kinds and kinds & set(range(1, 24))
    assert all(len(p.payload) <= 300 for p in packets)
    assert all([p.marker for p in group] == [False] * (len(group) - 1) + [True] for group in per_unit)
    assert len({p.ssrc for p in packets}) == 1

    result = depacketize_h264(shuffled_with_duplicates(packets, 1), first_sequence=packetizer.first_sequence)
    assert [u.data for u in result.units] == units       # start codes too: annexb follows libx264
    assert [u.timestamp for u in result.units] == timestamps
    assert not any(u.damaged for u in result.units)
    assert result.lost_sequences == [] and result.duplicate_packets == len(packets) // 5
    assert decode_access_units([u.data for u in result.units], "libx264") == (len(units), 0)


def test_h264_lost_fu_a_fragment_drops_that_nal_unit_and_flags_the_access_unit(streams):
    units = streams["libx264"]
    per_unit, timestamps = send(H264Packetizer(mtu=120, seed=4), units)
    victim = next(i for i, group in enumerate(per_unit) if len(h264_nal_units(units[i])) > 1
                  and sum(p.payload[0] & 0x1F == 28 for p in group[1:]) >= 3)
    middle = next(p for p in per_unit[victim][1:] if p.payload[0] & 0x1F == 28 and not p.payload[1] & 0xC0)
    packets = [p for group in per_unit for p in group if p is not middle]
    result = depacketize_h264(packets)
    assert result.lost_sequences == [unwrap_sequences([packets[0].sequence, middle.sequence])[1]]
    assert result.dropped_fragments == 1
    assert result.damaged_timestamps == [timestamps[victim]]
    damaged = result.units[victim]
    assert damaged.damaged and len(h264_nal_units(damaged.data)) == len(h264_nal_units(units[victim])) - 1
    assert [u.data for i, u in enumerate(result.units) if i != victim] == units[:victim] + units[victim + 1:]

    single = next(i for i, group in enumerate(per_unit) if len(h264_nal_units(units[i])) == 1 and len(group) > 2)
    packets = [p for group in per_unit for p in group if p is not per_unit[single][1]]
    result = depacketize_h264(packets)
    assert result.dropped_timestamps == [timestamps[single]] and result.damaged_timestamps == []
    assert [u.data for u in result.units] == units[:single] + units[single + 1:]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_h264_with_losses_still_decodes(streams, seed):
    units = streams["libx264"]
    per_unit, _ = send(H264Packetizer(mtu=300, seed=seed), units)
    later = [p for group in per_unit[1:] for p in group]
    dropped = Bernoulli(0.15, seed).decide(len(later))
    arrived = per_unit[0] + [p for p, lost in zip(later, dropped) if not lost]
    result = depacketize_h264(shuffled_with_duplicates(arrived, seed))
    assert len(result.lost_sequences) == int(dropped.sum()) > 0
    assert result.damaged_timestamps or result.dropped_timestamps
    assert decode_access_units([u.data for u in result.units], "libx264")[0] > 0


def test_h264_malformed_payloads_are_dropped_and_counted():
    slice_nal = b"\x65" + b"s" * 20
    malformed = [b"", b"\x78\x00\x09ab",               # STAP-A: length beyond the payload
                 b"\x78\x00\x00", b"\x7c\xc5abc",        # STAP-A zero length; FU-A with S and E set
                 b"\x7c", b"\x7c\x80",                     # FU-A without a header or a body
                 b"\x79\x00\x02ab", b"\x60abc"]           # STAP-B and type 0: not in non-interleaved mode
    packets = [RtpPacket(96, i, 0, 1, False, payload) for i, payload in enumerate(malformed)]
    packets.append(RtpPacket(96, len(malformed), 0, 1, True, slice_nal))
    result = depacketize_h264(packets)
    assert result.malformed_packets == len(malformed)
    assert [u.data for u in result.units] == [b"\x00\x00\x00\x01" + slice_nal]
    assert result.units[0].damaged


def test_lost_sequence_numbers_are_kept_as_ranges_whatever_numbers_arrive():
    packets = [RtpPacket(97, (i * 30_000) % 65536, i, 1, True, b"x") for i in range(300)]
    result = depacketize_mp4v(packets)
    assert len(result.lost_sequence_ranges) == 299
    assert result.lost_packets == 299 * 29_999
    assert len(result.units) == 300


# ------------------------------------------------------------------------------------------------ MP4V-ES


def test_mp4v_round_trips_and_partial_vops_are_flagged_or_dropped(streams):
    units = streams["mpeg4"]
    assert units[0].startswith(b"\x00\x00\x01\xb0") and units[1].startswith(b"\x00\x00\x01\xb6")
    packetizer = Mp4vPacketizer(mtu=120, seed=5)
    per_unit, timestamps = send(packetizer, units)
    packets = [p for group in per_unit for p in group]
    assert max(len(g) for g in per_unit) >= 3 and all(g[-1].marker and not g[0].marker for g in per_unit
                                                       if len(g) > 1)
    whole = depacketize_mp4v(shuffled_with_duplicates(packets, 2), packetizer.first_sequence)
    assert [u.data for u in whole.units] == units and [u.timestamp for u in whole.units] == timestamps
    assert decode_access_units([u.data for u in whole.units], "mpeg4") == (len(units), 0)

    victim = next(i for i, g in enumerate(per_unit) if i > 0 and len(g) >= 3)
    gone = per_unit[victim][1]
    arrived = [p for p in packets if p is not gone]
    partial = depacketize_mp4v(arrived, packetizer.first_sequence, partial=True)
    assert partial.damaged_timestamps == [timestamps[victim]]
    rebuilt = partial.units[victim]
    assert rebuilt.damaged and rebuilt.data == units[victim].replace(gone.payload, b"", 1)
    dropped = depacketize_mp4v(arrived, packetizer.first_sequence, partial=False)
    assert dropped.dropped_timestamps == [timestamps[victim]]
    assert [u.data for u in dropped.units] == units[:victim] + units[victim + 1:]


def test_mp4v_with_losses_still_decodes(streams):
    units = streams["mpeg4"]
    per_unit, _ = send(Mp4vPacketizer(mtu=120, seed=6), units)
    later = [p for group in per_unit[1:] for p in group]
    dropped = Bernoulli(0.2, 6).decide(len(later))
    arrived = per_unit[0] + [p for p, lost in zip(later, dropped) if not lost]
    result = depacketize_mp4v(shuffled_with_duplicates(arrived, 6))
    assert result.damaged_timestamps
    assert decode_access_units([u.data for u in result.units], "mpeg4")[0] > 0


def test_first_access_unit_is_damaged_when_its_head_is_lost_and_first_sequence_is_known(streams):
    units = streams["mpeg4"]
    packetizer = Mp4vPacketizer(mtu=120, seed=7)
    per_unit, timestamps = send(packetizer, units)
    packets = [p for group in per_unit for p in group][1:]
    assert depacketize_mp4v(packets, packetizer.first_sequence).damaged_timestamps == [timestamps[0]]
    assert depacketize_mp4v(packets).damaged_timestamps == []       # unknown start: assumed to start there


# ------------------------------------------------------------------------------------------------ parameter units


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_parameter_units_survive_exactly_when_all_their_packets_arrive(data):
    sizes = data.draw(st.lists(st.integers(1, 5000), min_size=1, max_size=30))
    mtu = data.draw(st.integers(rtp.MIN_MTU, 1500))
    rng = random.Random(data.draw(st.integers(0, 2**32)))
    units = [bytes(rng.getrandbits(8) for _ in range(size)) for size in sizes]
    packetizer = ParameterPacketizer(mtu=mtu, seed=rng.randrange(1000))
    packetizer.sequence = rng.choice([packetizer.sequence, 65530])   # exercise the wraps
    base = packetizer.unit_number = rng.choice([0, 65533])
    packets, owners = [], []          # owners: unit indices each packet carries bytes of
    index = 0
    while index < len(units):
        instant = units[index:index + rng.randint(1, 5)]
        for packet in packetizer.packetize_units(instant, 3000 * index):
            _, count, number = struct.unpack_from("!BBH", packet.payload)
            packets.append(packet)
            owners.append(range((number - base) % 65536, (number - base) % 65536 + count))
        index += len(instant)
    assert all(len(p.payload) <= mtu for p in packets)
    lost = set(data.draw(st.sets(st.integers(0, len(packets) - 1), max_size=len(packets))))
    arrived = [p for i, p in enumerate(packets) if i not in lost]
    arrived += rng.sample(arrived, len(arrived) // 4)
    rng.shuffle(arrived)

    result = depacketize_parameters(arrived)
    hit = {n for i in lost for n in owners[i]}
    expected = [n for n in range(len(units)) if n not in hit]
    assert [(u.number - base) % 65536 for u in result.units] == expected
    assert [u.data for u in result.units] == [units[n] for n in expected]
    assert result.stream == b"".join(units[n] for n in expected)
    seen = [n for i, o in enumerate(owners) if i not in lost for n in o]
    if seen:
        lost_units = {(n - base) % 65536 for n in result.lost_units}
        assert lost_units == {n for n in hit if min(seen) <= n <= max(seen)}
    assert result.malformed_packets == 0


def test_parameter_packets_aggregate_small_units_and_fragment_large_ones():
    packetizer = ParameterPacketizer(mtu=100, seed=1)
    packets = packetizer.packetize_units([b"a" * 10, b"b" * 20, b"c" * 250, b"d" * 5], 9000)
    headers = [struct.unpack_from("!BBH", p.payload) for p in packets]
    assert headers == [(0xC0, 2, 0), (0x80, 1, 2), (0x00, 1, 2), (0x40, 1, 2), (0xC0, 1, 3)]
    assert [p.marker for p in packets] == [False, False, False, False, True]
    assert {p.timestamp for p in packets} == {9000}


def test_parameter_depacketizer_drops_malformed_payloads_and_counts_them():
    packetizer = ParameterPacketizer(mtu=100, seed=2)
    good = packetizer.packetize_units([b"unit-one", b"unit-two"], 0)[0]
    bad_payloads = [b"", b"\xc0\x01", b"\xc0\x02\x00\x00\x00\x03abc", b"\xc0\x01\x00\x00\x00\x09abc",
                    b"\xc0\x01\x00\x00\x00\x03abcX", b"\x80\x02\x00\x00xyz", b"\xc0\x00\x00\x00"]
    bad = [RtpPacket(98, (good.sequence + 1 + i) % 65536, 3000, good.ssrc, True, payload)
           for i, payload in enumerate(bad_payloads)]
    result = depacketize_parameters([good, *bad])
    assert [u.data for u in result.units] == [b"unit-one", b"unit-two"]
    assert result.malformed_packets == len(bad_payloads)


# ------------------------------------------------------------------------------------------------ robustness


packet_strategy = st.builds(RtpPacket, st.just(96), st.integers(0, 65535), st.sampled_from([0, 3000, 6000]),
                            st.just(1), st.booleans(),
                            st.one_of(st.binary(max_size=40),
                                      st.tuples(st.sampled_from([b"\x7c", b"\x78", b"\x5c\x85", b"\xc0\x02",
                                                                 b"\x80\x01\x00\x00", b"\x40\x01"]),
                                                st.binary(max_size=30)).map(b"".join)))


@settings(max_examples=300, deadline=None)
@given(st.lists(packet_strategy, max_size=25), st.one_of(st.none(), st.integers(0, 65535)))
def test_depacketizers_never_raise_on_arbitrary_packets(packets, first_sequence):
    for depacketize in (depacketize_h264, depacketize_mp4v, depacketize_parameters):
        result = depacketize(packets, first_sequence)
        assert all(isinstance(u.data, bytes) for u in result.units)
    assert depacketize_h264([]).units == []
