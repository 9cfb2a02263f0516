"""Live delivery on real loopback sockets (pipeline/live): sessions with and without loss deliver, conceal and
report every lost frame; the chain encode -> packetise -> lose -> depacketise -> decode stays within bounds over
random motions and loss patterns; `signcast send` / `signcast receive` run as two processes; `signcast live`
writes records, a chart and a transport stream; bad input is one line."""
import os
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from comparisons.transport import fba_units
from comparisons.reports import live as live_report
from comparisons.transport import loss as loss_models
from comparisons.transport import rtp
from comparisons.reports.records import as_records, read_records
from media.avatar import load_avatar
from media.fingerspelling import fingerspell
from media.render import AvatarRenderer, RenderSettings
from pipeline.cli import main
from pipeline.live import endpoints
from pipeline.live.session import SessionDescription
from pipeline.studies import live

SIZE = (176, 144)


@pytest.fixture(scope="module")
def letter():
    return fingerspell("ase", "A")


@pytest.fixture(scope="module")
def renderer():
    return AvatarRenderer(load_avatar(), RenderSettings(width=SIZE[0], height=SIZE[1]))


def _session(codec, motion, renderer, model, refresh=8, frames=None, q=4):
    solution = live.solution_for(codec)
    payload, source = endpoints.source_for(solution, codec, q, frames=frames, motion=motion, fps=motion.fps,
                                           refresh=refresh)
    description = SessionDescription(solution, codec, payload, q, motion.fps, motion.n_frames, *SIZE, clip="A")
    endpoints.warm_up(codec, renderer, motion)
    return live.deliver(description, source, lambda d: endpoints.sink_for(d, lambda w, h: renderer), model)


def _no_loss():
    return loss_models.NetworkModel(loss_models.Bernoulli(0.0))


def test_fba_session_without_loss_shows_every_frame_as_decoded(letter, renderer):
    delivery = _session("fba-pred", letter, renderer, _no_loss())
    got = delivery.received
    assert got.received.all() and delivery.relay_counts.dropped == 0
    assert got.packets == delivery.sent.packets and got.late_packets == 0
    units = fba_units.find_units(b"".join(part for unit in delivery.sent.access_units for part in unit.data))[0]
    assert [u.first_frame for u in units] == list(range(0, letter.n_frames, 8))
    codec = endpoints.param_codecs.get_codec("fba-pred")
    expected = np.concatenate([np.stack([rgb for rgb, _ in renderer.frames(codec.decode(_payload(delivery, k)))])
                               for k in range(len(units))])
    assert np.array_equal(got.shown, expected)
    p50, p95 = got.latency_summary()
    assert 0 < p50 <= p95 < 5000


def _payload(delivery, k: int) -> bytes:
    data = delivery.sent.access_units[k].data[0]
    return data[fba_units.HEADER_BYTES:]


def test_lossy_session_conceals_and_reports_every_lost_frame(letter, renderer):
    delivery = _session("fba-dct", letter, renderer, loss_models.NetworkModel(loss_models.Bernoulli(0.5, seed=3),
                                                                             seed=3), refresh=4)
    got = delivery.received
    assert delivery.relay_counts.dropped > 0
    lost = ~got.received
    assert 0 < lost.sum() < letter.n_frames
    assert np.all(np.isnan(got.latency_ms[lost])) and np.all(np.isfinite(got.latency_ms[~lost]))
    arrived = np.flatnonzero(got.received)
    for t in np.flatnonzero(lost):                    # a lost frame holds the last shown one (the first before any)
        before = arrived[arrived < t]
        source = before[-1] if len(before) else arrived[0]
        assert np.array_equal(got.shown[t], got.shown[source])
    assert got.packets + delivery.relay_counts.dropped == delivery.sent.packets


def test_nsv_session_decodes_and_conceals_lost_packets(letter, renderer):
    frames = np.stack([rgb for rgb, _ in renderer.frames(letter)])
    clean = _session("mpeg4", letter, renderer, _no_loss(), frames=frames)
    assert clean.received.received.all() and clean.received.sink_stats["damaged"] == 0
    error = np.abs(clean.received.shown.astype(int) - frames).mean()
    assert error < 3.0
    lossy = _session("mpeg4", letter, renderer, loss_models.NetworkModel(loss_models.Bernoulli(0.3, seed=5), seed=5),
                     frames=frames)
    assert lossy.relay_counts.dropped > 0
    assert not lossy.received.received.all()
    assert lossy.received.shown.shape == frames.shape


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(0, 2 ** 31), st.integers(1, 12), st.integers(40, 400), st.floats(0.0, 0.6))
def test_encode_packetise_lose_depacketise_decode_stays_in_bounds(seed, refresh, mtu, loss):
    rng = np.random.default_rng(seed)
    n_frames = int(rng.integers(5, 40))
    values = np.zeros((n_frames, 296), np.int64)
    moving = rng.choice(296, 6, replace=False)
    values[:, moving] = np.cumsum(rng.integers(-400, 400, (n_frames, 6)), axis=0)
    units = fba_units.encode_fba_units(values, 25.0, 2, "pred", refresh=refresh)
    packetizer = rtp.ParameterPacketizer(mtu=mtu, seed=seed % 1000)
    sent = [(unit, packetizer.packetize_units([unit.data], rtp.timestamp_of(unit.first_frame, 25.0)))
            for unit in units]
    dropped = loss_models.Bernoulli(loss, seed=seed).decide(sum(len(p) for _, p in sent))
    arrived, k, whole = [], 0, []
    for unit, packets in sent:
        kept = [p for p, gone in zip(packets, dropped[k:k + len(packets)]) if not gone]
        whole.append(len(kept) == len(packets))
        arrived += kept
        k += len(packets)
    stream = rtp.depacketize_parameters(arrived, packetizer.first_sequence).stream
    decoded, _ = fba_units.find_units(stream)
    expected = np.zeros(n_frames, bool)
    for unit, ok in zip(units, whole):
        expected[unit.first_frame:unit.first_frame + unit.n_frames] = ok
    if not expected.any():
        assert decoded == []
        return
    received = fba_units.assemble(decoded, n_frames)
    assert np.array_equal(received.received, expected)
    assert sum(n for _, n in received.lost_units) == received.concealed == (~expected).sum()
    assert received.baps.shape == values.shape
    step = 2 * fba_units.fba_codec.BAPS.base_steps
    assert np.all(received.baps >= values.min(axis=0) - step) and np.all(received.baps <= values.max(axis=0) + step)


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as udp:
        udp.bind(("127.0.0.1", 0))
        return udp.getsockname()[1]


def test_send_and_receive_commands_run_as_two_processes(tmp_path, capsys):
    port = _free_port()
    out = tmp_path / "received"
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[1]))
    receiver = subprocess.Popen([sys.executable, "-m", "pipeline.cli", "receive", "--port", str(port), "--out", str(out),
                                 "--timeout", "120"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                env=env, cwd=str(Path(__file__).resolve().parents[1]))
    try:
        assert receiver.stderr.readline().startswith("listening on")
        assert main(["send", "ase", "A", "--codec", "fba-dct", "--q", "4", "--to", f"127.0.0.1:{port}", "--loss", "30",
                     "--refresh", "4", "--size", "176x144", "--no-progress"]) == 0
        stdout, stderr = receiver.communicate(timeout=120)
    finally:
        receiver.kill()
    assert receiver.returncode == 0, stderr
    assert "sent ase-A as FBA" in capsys.readouterr().out
    assert stdout.startswith("received ase-A as FBA (fba-dct)")
    record = read_records(out / "records.jsonl")[0]
    assert record["frames_lost"] >= 0 and record["packets_received"] > 0
    assert (out / "shown.mkv").stat().st_size > 0


@pytest.fixture(scope="module")
def live_run(tmp_path_factory):
    """`signcast live` on one letter, FBA, NSV and SSV, at 0 and 40 % loss: (out folder, what it printed)."""
    import contextlib
    import io
    out = tmp_path_factory.mktemp("live") / "out"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        code = main(["live", "ase", "A", "--codecs", "fba-pred,mpeg4,SSV", "--loss-rates", "0,40", "--refresh", "4",
                     "--size", "176x144", "--landmark-step", "4", "--seed", "2", "--no-progress", "--out", str(out)])
    assert code == 0
    return out, printed.getvalue()


def test_live_command_writes_records_chart_and_transport_streams(live_run):
    out, text = live_run
    assert "fba-pred" in text and "report:" in text
    records = read_records(out / "records.jsonl")
    points = live_report.loss_points(records)
    assert {(r["solution"], r["codec"], r["loss_rate"]) for r in points} == {
        (solution, codec, loss) for solution, codec in (("FBA", "fba-pred"), ("NSV", "mpeg4"), ("SSV", "mpeg4"))
        for loss in (0.0, 0.4)}
    for r in points:
        assert r["delivered_kbps"] > r["kbps"] > 0 and r["hand_pck_20"] is not None
        arrived = 21 - r["frames_lost"]                 # ASL A: 21 frames; latency only over frames that arrived
        assert (r.get("latency_ms_p50") or 0) > 0 if arrived else r.get("latency_ms_p50") is None
    clean = [r for r in points if r["loss_rate"] == 0]
    assert all(r["frames_lost"] == 0 and r["packet_loss"] == 0 for r in clean)
    streams = [r for r in records if r["kind"] == "transport stream"]
    assert {r["solution"] for r in streams} == {"FBA", "NSV", "SSV"} and all(r["demuxed_intact"] for r in streams)
    assert all((out / r["file"]).stat().st_size % 188 == 0 for r in streams)
    assert (out / "live_loss.png").stat().st_size > 10_000
    assert "Intelligibility and latency against loss" in (out / "report.html").read_text()


def test_live_report_renders_in_headless_chromium(live_run):
    browser = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if browser is None:
        pytest.skip("Chromium is not installed (Debian: apt-get install chromium); .ci/run installs it")
    dom = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--virtual-time-budget=5000",
                          "--dump-dom", (live_run[0] / "report.html").as_uri()],
                         capture_output=True, text=True, timeout=120).stdout
    check = dom.split('id="render-check">', 1)[1].split("<", 1)[0] if 'id="render-check">' in dom else dom[-300:]
    assert check.startswith("rendered 1/1 charts, ") and check.endswith("; all ok"), check
    tables = int(check.split(", ")[1].split("/")[0])
    assert tables >= 2 and f"{tables}/{tables} tables" in check          # loss sweep, latency stages, TS


@pytest.mark.parametrize("argv, fragment", [
    (["live", "--loss-rates", "150", "--out", "{tmp}/x"], "outside 0..100"),
    (["live", "--codecs", "fba-nope", "--out", "{tmp}/x"], "give an MPEG-4 parameter codec (fba-pred"),
    (["live", "--refresh", "0", "--out", "{tmp}/x"], "refresh period"),
    (["send", "ase", "A", "--to", "127.0.0.1:{port}"], "cannot reach the receiver"),
    (["send", "ase", "A", "--to", "nowhere"], "bad address"),
    (["receive", "--port", "0", "--out", "{tmp}/y"], "--port"),
    (["receive", "--port", "{port}", "--timeout", "0.3", "--out", "{tmp}/z"], "no sender connected"),
])
def test_bad_input_is_one_line(tmp_path, capsys, argv, fragment):
    port = str(_free_port())
    argv = [a.replace("{tmp}", str(tmp_path)).replace("{port}", port) for a in argv]
    code = main(argv)
    lines = capsys.readouterr().err.strip().splitlines()
    error = lines[-1]                                 # receive says where it listens first
    assert code == 2 and "Traceback" not in "\n".join(lines) and len(lines) <= 2
    assert error.startswith(f"signcast {argv[0]}: error: ") and fragment in error


def test_live_report_charts_and_prints_face_error_for_a_clip_without_hands():
    """A head-and-shoulders clip (carphone) has no hand keypoints: the report charts and prints its face error."""
    records = [{"kind": "point", "sweep": "loss", "solution": solution, "codec": codec, "q": 8, "fps": 25.0,
                "loss_rate": loss,
                "kbps": kbps, "delivered_kbps": kbps * 1.1, "frames_lost": lost, "hand_pck_20": None,
                "face_error": error, "latency_ms_p50": 10.0, "latency_ms_p95": 20.0}
               for solution, codec, kbps in (("NSV", "mpeg4", 141.6), ("FBA", "fba-pred", 15.9))
               for loss, lost, error in ((0.0, 0, 0.052), (0.1, 9, 0.074))]
    points = live_report.loss_points(records)
    figure = live_report.chart(points)
    axes = figure.get_axes()
    assert len(axes) == 2 and "face error" in axes[0].get_ylabel()
    assert sorted(tuple(line.get_ydata()) for line in axes[0].get_lines()) == [(0.052, 0.074), (0.052, 0.074)]
    text = live_report.summary_text(as_records(records))
    assert "face" in text.splitlines()[0] and "0.052" in text and "0.074" in text
