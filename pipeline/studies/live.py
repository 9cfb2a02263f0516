"""The loss sweep (`signcast live`): each solution delivered live over RTP/UDP on the loopback interface through a
lossy relay, at each loss rate, and judged by what the receiver shows.

For every solution at its operating point (codec and Q given by the settings) and every loss rate, one session
runs on real sockets: the sender captures the signing at its own frame rate (pipeline/live/session.py), encodes
it live, packetises it (comparisons.transport.rtp) and sends it through a relay that drops, delays and reorders datagrams
with a seeded model (comparisons.transport.loss: Bernoulli, or Gilbert-Elliott bursts); the receiver depacketises,
decodes, conceals, renders (FBA, BBA), and time-stamps each frame when it is ready to show. Then the frames it
showed are judged as `signcast compare` judges a point (comparisons.judging.judge.Judge: landmarks re-extracted,
hand keypoint error and PCK, letters), against the same references; one extraction per point, under the
half-pixel shift that is compare's first (comparisons.judging.landmark_draws: a live point is one of --repeats).

Per point the record carries the stream's kbps (its own bytes over the clip's duration), delivered_kbps (whole
datagrams: IPv4 20 + UDP 8 bytes + the RTP packet), the measured packet loss, the frames lost and concealed, the
latency median and 95th percentile (capture to ready-to-show, per received frame), and the intelligibility
fields. At loss 0 each solution is also muxed with a programme video into an MPEG-2 transport stream through PyAV
(comparisons.transport.ts), demuxed back, and its TS overhead measured from the packets (one "transport
stream" record per solution). The scenario is compare's word or pose scenario (the avatar fingerspelling a word,
or a .pose retargeted), whose lossless render NSV codes as its natural video.
"""
from __future__ import annotations

import dataclasses

import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
from tqdm import tqdm

from comparisons.judging.judge import Judge, Viewed
from comparisons.reports.records import Record, as_records, make_record, versions
from pipeline.outputs import write_outputs, write_records
from comparisons.transport import loss as loss_models
from media.avatar import load_avatar
from media.domain import Solution, kbps, solution_of
from media.errors import SigncastError
from media.render import AvatarRenderer, RenderSettings
from pipeline.live import endpoints
from pipeline.live.network import LossyRelay  # noqa: F401 (tests use live.LossyRelay)
from pipeline.live.session import Listener, SessionDescription, receive, send
from pipeline.stages import StageClock
from pipeline.studies import shared

LOSS_RATES = (0.0, 0.005, 0.01, 0.02, 0.05, 0.10)   # fraction of datagrams lost (0..1)
EN_301_549_PREFERRED_MS = 400.0                      # EN 301 549 guidance: under 0.4 s preferred,
EN_301_549_HINDERS_MS = 800.0                        # over 0.8 s hinders conversation
IP_UDP_BYTES = 28


@dataclass(frozen=True)
class LiveSettings:
    """codecs: what is sent, each a parameter codec (fba-*, bba-*: FBA, BBA), a video solution (NSV, NSV2O, NSV3O,
    NSV3O+C, SSV: with mpeg4), a live video codec (mpeg4, libx264: NSV) or SOLUTION:codec (e.g. SSV:libx264);
    video_q, param_q: their quantisers; shape_gop: frames per shape unit of the video objects;
    loss_rates: fractions (0..1) of datagrams lost (the CLI takes percent); burst: mean loss burst length in packets (1: Bernoulli, more:
    Gilbert-Elliott); jitter_ms: the relay's delay spread; reorder: share of datagrams held back past their
    successor; refresh: the FBA/BBA intra refresh period in frames; units: "frame" (low delay: a unit per frame,
    intra every refresh frames, delta units between) or "period" (one unit per refresh frames); seed: the network model's seed; repeats: sessions per codec and
    loss rate, each with its own seed (losses of a few packets are chance: the report gives their mean and range);
    language, word, pose, size,
    landmark_step, backend: the scenario, as in `signcast compare`."""
    codecs: tuple[str, ...] = (*Solution.video(), "fba-pred", "fba-dct", "bba-pred", "bba-dct")
    video_q: int | None = None         # None: each video codec's own default (DEFAULT_VIDEO_Q)
    param_q: int = 4
    loss_rates: tuple[float, ...] = LOSS_RATES
    burst: float = 1.0
    jitter_ms: float = 0.0
    reorder: float = 0.0
    refresh: int = 25
    units: str = "frame"
    seed: int = 1
    repeats: int = 1
    shape_gop: int = 1
    language: str = "ase"
    word: str = "HELLO"
    pose: str | None = None
    size: tuple[int, int] = (352, 288)
    landmark_step: int = 3
    backend: str = "auto"

    def signing(self) -> shared.ScenarioSettings:
        """The scenario (compare's word or pose scenario)."""
        return shared.ScenarioSettings(language=self.language, word=self.word, pose=self.pose, size=self.size,
                                       backend=self.backend)


VIDEO_SOLUTIONS = Solution.video()
DEFAULT_VIDEO_CODEC = "mpeg4"
# Each video codec's own default quantiser, on its own scale: MPEG-4 Q 4 (1..31); x264 constant QP 28 (0..51),
# where a signer at 352x288 and 25 fps costs about what MPEG-4 Q 4 does (one number for both would be x264 QP 4,
# over a megabit a second: an easy way to a misleading H.264 figure).
DEFAULT_VIDEO_Q = {"mpeg4": 4, "libx264": 28}
DEFAULT_PARAM_Q = 4


def parse_send(item: str) -> tuple[str, str, int | None]:
    """(solution, codec, Q or None for the default) of one --codecs item: 'fba-pred', 'fba-pred:8', 'NSV2O',
    'NSV2O:mpeg4:8', 'mpeg4' (NSV) or 'SSV:libx264:26'."""
    from comparisons.params import codecs as param_codecs
    parts = [part.strip() for part in item.strip().split(":")]
    q_text = None
    if parts[0] in param_codecs.codec_names():
        solution, codec = solution_of(parts[0]), parts[0]
        rest = parts[1:]
        if not solution.mpeg4_parameters:
            raise SigncastError(f"{codec!r} is a {solution}, not an MPEG-4 stream: live delivery sends FBA and BBA")
    else:
        solution = "NSV" if parts[0] in endpoints.VIDEO_CODECS else parts[0].upper()
        codec = parts[0] if parts[0] in endpoints.VIDEO_CODECS else DEFAULT_VIDEO_CODEC
        rest = parts[1:]
        if rest and not rest[0].lstrip("-").isdigit():
            codec, rest = rest[0], rest[1:]
        if solution not in VIDEO_SOLUTIONS or codec not in endpoints.VIDEO_CODECS:
            mpeg4 = [name for name in param_codecs.codec_names() if solution_of(name).mpeg4_parameters]
            raise SigncastError(f"cannot send {item!r} live: give an MPEG-4 parameter codec ({', '.join(mpeg4)}), "
                                f"a video codec ({', '.join(endpoints.VIDEO_CODECS)}: NSV), one of "
                                f"{', '.join(VIDEO_SOLUTIONS)}, or SOLUTION:CODEC[:Q] with a video solution and "
                                f"{' or '.join(endpoints.VIDEO_CODECS)}")
    if len(rest) > 1:
        raise SigncastError(f"cannot send {item!r} live: too many ':' parts")
    if rest:
        q_text = rest[0]
        try:
            q = int(q_text)
        except ValueError:
            raise SigncastError(f"bad Q {q_text!r} in {item!r}: give a whole number") from None
        low, high = (1, 31) if Solution(solution).mpeg4_parameters or codec == "mpeg4" else (0, 51)
        if not low <= q <= high:
            raise SigncastError(f"Q {q} in {item!r} is outside {low}..{high}")
        return solution, codec, q
    return solution, codec, None


def solution_for(codec: str) -> str:
    return parse_send(codec)[0]


def check(settings: LiveSettings) -> None:
    """Refuse bad settings before any work starts."""
    if not settings.codecs:
        raise SigncastError("give at least one codec")
    sends = [parse_send(item)[:2] for item in settings.codecs]
    if len(set(sends)) != len(sends):
        raise SigncastError("--codecs names the same solution and codec twice")
    if not 1 <= settings.shape_gop <= 65535:
        raise SigncastError(f"the shape unit must be 1..65535 frames, got {settings.shape_gop}")
    for rate in settings.loss_rates:
        if not 0.0 <= rate < 1.0:
            raise SigncastError(f"loss rate {100 * rate:g} % is outside 0..100 %")
    if not settings.burst >= 1.0:
        raise SigncastError(f"the mean loss burst must be at least 1 packet, got {settings.burst:g}")
    if settings.jitter_ms < 0 or not 0.0 <= settings.reorder <= 1.0:
        raise SigncastError("jitter must be >= 0 ms and the reorder share within 0..1")
    if not 1 <= settings.refresh <= 65535:
        raise SigncastError(f"the refresh period must be 1..65535 frames, got {settings.refresh}")
    if settings.units not in endpoints.UNIT_MODES:
        raise SigncastError(f"unknown unit mode {settings.units!r}: choose {' or '.join(endpoints.UNIT_MODES)}")
    if not 1 <= settings.repeats <= 100:
        raise SigncastError(f"--repeats must be 1..100, got {settings.repeats}")
    if not 1 <= settings.param_q <= 31:
        raise SigncastError(f"--param-q must be 1..31, got {settings.param_q}")
    shared.check_landmark_step(settings.landmark_step)
    shared.check_scenario(settings.signing())


def network_model(settings: LiveSettings, rate: float, seed: int) -> loss_models.NetworkModel:
    """The relay's model at one loss rate (fraction of datagrams, 0..1)."""
    if settings.burst > 1.0 and rate > 0:
        loss = loss_models.GilbertElliott.from_rate(rate, settings.burst, seed=seed)
    else:
        loss = loss_models.Bernoulli(rate, seed=seed)
    return loss_models.NetworkModel(loss, jitter_ms=settings.jitter_ms, reorder_rate=settings.reorder, seed=seed)


@dataclass
class Delivery:
    """One session's outcome: what was sent and what was shown."""
    sent: object
    received: object
    relay_counts: object


def deliver(description: SessionDescription, source, sink_for: Callable, model) -> Delivery:
    """Runs one session on loopback sockets: a receiver thread, the relay thread, the sender here."""
    listener = Listener()
    outcome: dict = {}

    def receiver() -> None:
        try:
            outcome["received"] = receive(listener, sink_for)
        except BaseException as error:          # re-raised in the caller's thread
            outcome["error"] = error

    try:
        with LossyRelay(listener.address, model) as relay:
            thread = threading.Thread(target=receiver, name="live-receiver", daemon=True)
            thread.start()
            sent = send(description, source, listener.address, relay=relay)
            thread.join()
    finally:
        listener.close()
    if "error" in outcome:
        raise outcome["error"]
    return Delivery(sent, outcome["received"], relay.counts)


def delivery_fields(got, packets_sent: int | None, relay_dropped: int | None) -> dict:
    """What a session's datagrams came to, kept apart (issue 37): packet_loss is what the network lost (the
    relay's loss model, over the datagrams sent); late_packets were read after their frame was shown or after
    the session; unaccounted_packets were sent and neither dropped by the relay nor read (lost in the host: a
    full socket buffer); discarded, malformed and unknown datagrams were refused by the receiver's checks. Also
    the latency, whole and per stage (p50 / p95 ms), the jitter buffer's hold and measured jitter, and what the
    control port refused."""
    packets_sent = got.packets_sent if got.packets_sent is not None else packets_sent
    relay_dropped = got.relay_dropped if got.relay_dropped is not None else relay_dropped
    p50, p95 = got.latency_summary()
    unaccounted = (None if packets_sent is None else
                   max(0, packets_sent - (relay_dropped or 0) - (got.packets - got.discarded_packets
                                                               - got.malformed_packets - got.unknown_packets)))
    fields = {"packet_loss": None if not packets_sent else (relay_dropped or 0) / packets_sent,
              "packets": packets_sent, "packets_received": got.packets, "relay_dropped": relay_dropped,
              "late_packets": got.late_packets, "drained_packets": got.drained_packets,
              "unaccounted_packets": unaccounted, "discarded_packets": got.discarded_packets,
              "malformed_packets": got.malformed_packets, "unknown_packets": got.unknown_packets,
              "stalled_connections": got.control.stalled, "rejected_descriptions": got.control.rejected,
              "refused_connections": got.control.refused, "latency_ms_p50": p50, "latency_ms_p95": p95,
              "hold_ms": got.hold_ms, "jitter_measured_ms": got.jitter_ms,
              "en_301_549": latency_verdict(p95)}
    for stage, (a, b) in got.stage_summary().items():
        fields[f"{stage}_ms_p50"], fields[f"{stage}_ms_p95"] = a, b
    return fields


def latency_verdict(p95_ms: float | None) -> str | None:
    """EN 301 549 (clause 6.5) on a session's 95th-percentile latency: "preferred" under 0.4 s, "acceptable" up
    to 0.8 s, "hinders" above (conversation is hindered)."""
    if p95_ms is None:
        return None
    return ("preferred" if p95_ms < EN_301_549_PREFERRED_MS else
            "acceptable" if p95_ms <= EN_301_549_HINDERS_MS else "hinders")


def _damaged_frames(sink_stats: dict) -> int:
    """Frames a video decoder showed from damaged data (FFmpeg's concealment inside the picture): NSV's decoder
    stats, or the most of any object's texture decoder."""
    if "damaged" in sink_stats:
        return int(sink_stats["damaged"])
    textures = [value["texture"] for value in sink_stats.values() if isinstance(value, dict) and "texture" in value]
    return max((int(texture.get("damaged", 0)) for texture in textures), default=0)


class LiveStudy:
    def __init__(self, settings: LiveSettings, scenario: shared.Scenario, renderer_for, progress: bool):
        self.settings, self.scenario, self.renderer_for, self.progress = settings, scenario, renderer_for, progress
        self.judge = Judge(scenario, settings.landmark_step, shared.letter_recogniser(scenario))

    def q_of(self, solution: str, codec: str, q: int | None = None) -> int:
        """The item's own Q, or the settings' video / parameter Q, or the video codec's own default."""
        if q is not None:
            return q
        if solution not in VIDEO_SOLUTIONS:
            return self.settings.param_q
        return self.settings.video_q if self.settings.video_q is not None else DEFAULT_VIDEO_Q[codec]

    def description(self, solution: str, codec: str, payload: str, q: int) -> SessionDescription:
        s, scenario = self.settings, self.scenario
        width, height = scenario.size
        details = ({"refresh": s.refresh, "units": s.units} if Solution(solution).mpeg4_parameters else
                   {"shape_gop": s.shape_gop} if solution != "NSV" else {})
        return SessionDescription(solution, codec, payload, q, scenario.fps, scenario.n_frames,
                                  width, height, clip=scenario.name, details=details)

    def source(self, solution: str, codec: str, q: int):
        """(payload format, source): SSV sends the lossless render cut by its label buffer, the NSV family the
        reference frames cut by their segmentation, FBA and BBA the motion."""
        scenario = self.scenario
        frames, labels = ((scenario.render, scenario.render_labels) if solution == "SSV"
                          else (scenario.frames, scenario.labels))
        return endpoints.source_for(solution, codec, q, frames=frames, labels=labels,
                                    motion=scenario.motion, fps=scenario.fps, refresh=self.settings.refresh,
                                    shape_gop=self.settings.shape_gop, units=self.settings.units)

    def point(self, send_item: str, rate: float, seed: int) -> tuple[list[dict], Delivery]:
        """Deliver one solution and codec at one loss rate and judge what was shown: one record per reference."""
        solution, codec, q = parse_send(send_item)
        q = self.q_of(solution, codec, q)
        payload, source = self.source(solution, codec, q)
        description = self.description(solution, codec, payload, q)
        endpoints.warm_up(codec, self.renderer_for(*self.scenario.size), self.scenario.motion)
        delivery = deliver(description, source, lambda d: endpoints.sink_for(d, self.renderer_for),
                           network_model(self.settings, rate, seed))
        got = delivery.received
        s = self.scenario
        duration = s.timing.duration_s
        sent = delivery.sent
        delivered_bits = 8 * (sent.rtp_bytes + IP_UDP_BYTES * sent.packets)
        frames_lost = int((~got.received).sum())
        damaged = _damaged_frames(got.sink_stats)
        fields = make_record(description.solution, s.name, codec, description.q, s.fps, *s.size,
                             8 * sent.media_bytes, duration, sweep="loss", loss_rate=rate,
                             delivered_kbps=kbps(delivered_bits, duration),
                             overhead_kbps=kbps(delivered_bits - 8 * sent.media_bytes, duration),
                             frames_lost=frames_lost, frames_concealed=frames_lost + damaged,
                             refresh=description.details.get("refresh"), units=description.details.get("units"),
                             shape_gop=description.details.get("shape_gop"),
                             burst=self.settings.burst, jitter_ms=self.settings.jitter_ms, seed=seed,
                             **delivery_fields(got, sent.packets, delivery.relay_counts.dropped))
        draws = shared.extract_draws(got.shown[self.judge.measured], s.fps, 1,
                                     f"landmarks: {codec} at {100 * rate:g} % loss", self.progress)
        viewed = Viewed(got.shown, None, fields)
        return self.judge.records(description.solution, viewed, draws), delivery


def run(settings: LiveSettings, out_dir: str | Path, *, progress: bool = True) -> list[Record]:
    """The loss sweep: records.jsonl (streamed as points finish), live_table.csv, live_loss.png, report.html."""
    from comparisons.reports import live as live_report
    check(settings)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    records_path = write_records(out_dir / "records.jsonl", [])
    clock = StageClock()
    renderer_for = shared.renderers(settings.backend)
    with clock.stage("scenario: reference, landmarks, lossless render"):
        scenario = shared.load_scenario(settings.signing(), renderer_for, progress=progress)
        renderer_for(*scenario.size)
    study = LiveStudy(settings, scenario, renderer_for, progress)
    records: list[dict] = []
    points = [(codec, rate, repeat) for codec in settings.codecs for rate in settings.loss_rates
              for repeat in range(settings.repeats)]
    with clock.stage("live sessions and judging"), tqdm(total=len(points), desc="live points", unit="point",
                                                         disable=not progress) as bar:
        for k, (codec, rate, repeat) in enumerate(points):
            bar.set_postfix_str(f"{codec} {100 * rate:g} %")
            point_records, delivery = study.point(codec, rate, settings.seed + k)
            for record in point_records:
                record["repeat"] = repeat
            records += point_records
            write_records(records_path, point_records, append=True)
            if rate == 0 and repeat == 0:
                ts_record = transport_stream_record(scenario, delivery, out_dir)
                records.append(ts_record)
                write_records(records_path, [ts_record], append=True)
            bar.update(1)
    run_record = {"kind": "run", "backend": settings.backend, "versions": versions(), "clip": scenario.name,
                  "clip_fps": scenario.fps, "clip_frames": scenario.n_frames, "burst": settings.burst,
                  "jitter_ms": settings.jitter_ms, "reorder": settings.reorder, "refresh": settings.refresh,
                  "units": settings.units,
                  "seed": settings.seed, "repeats": settings.repeats, "latency_guidance_ms": [EN_301_549_PREFERRED_MS, EN_301_549_HINDERS_MS]}
    all_records = as_records([run_record] + records + clock.records())
    write_records(out_dir / "records.jsonl", all_records)
    write_outputs(out_dir, live_report.report_outputs(all_records))
    return all_records


def transport_stream_record(scenario: shared.Scenario, delivery: Delivery, out_dir: Path) -> dict:
    """The session's access units muxed with a programme video (carphone, the bundled natural clip, scaled to the
    signer's size and looped to the clip's duration, H.264) into an MPEG-2 TS written to out_dir/ts/, demuxed back
    and checked against what was sent, and the signer stream's TS overhead measured from the TS packets."""
    import shutil
    import subprocess

    import cv2

    from comparisons.transport import ts
    from media.video_io import bundled_clip_path, read_video
    description = delivery.received.description
    units = delivery.sent.access_units
    programme_frames, programme_fps = read_video(bundled_clip_path("carphone"))
    n_programme = max(1, int(np.ceil(scenario.timing.duration_s * programme_fps)))
    width, height = scenario.size
    programme_frames = np.stack([cv2.resize(programme_frames[k % len(programme_frames)], (width, height),
                                            interpolation=cv2.INTER_AREA) for k in range(n_programme)])
    programme = ts.encode_programme(programme_frames, programme_fps)
    names = [stream["name"] for stream in description.streams]
    payloads = [stream["payload"] for stream in description.streams]
    by_stream: list[list] = [[] for _ in names]
    for unit in units:
        by_stream[unit.stream].append(unit)
    signer_video, signer_data = [], []
    texture_codec = description.codec if description.codec in endpoints.VIDEO_CODECS else None
    for name, payload, sent in zip(names, payloads, by_stream):
        if payload == "units":
            kind = "shape" if name.endswith("/shape") else description.solution.lower()
            signer_data.append(ts.ParameterTrack(kind, description.fps,
                                                 [(unit.frame, part) for unit in sent for part in unit.data]))
        else:
            signer_video.append(ts.ElementaryVideo(name, texture_codec, description.fps, width, height,
                                                   [unit.data for unit in sent], [unit.frame for unit in sent],
                                                   [unit.frame % endpoints.LIVE_GOP == 0 for unit in sent]))
    data = ts.mux_transport_stream(programme, signer_video, signer_data)
    folder = out_dir / "ts"
    folder.mkdir(exist_ok=True)
    path = folder / f"{description.solution}-{description.codec}.ts"
    path.write_bytes(data)
    demuxed = ts.demux_transport_stream(data)
    signer = [stream for stream in demuxed.streams if stream.index > 0]
    videos = [stream for stream in signer if stream.kind == "video"]
    tracks = [stream for stream in signer if stream.kind != "video"]
    intact = (len(videos) == len(signer_video) and len(tracks) == len(signer_data)
              and all(len(got.packets) == len(video.packets) for got, video in zip(videos, signer_video))
              and all([unit for _, unit in got.units] == [part for _, part in track.units]
                      for got, track in zip(tracks, signer_data)))
    if not intact:
        raise SigncastError(f"the transport stream {path.name} did not give back the signer's streams")
    costs = ts.stream_overheads(ts.ts_overhead(data, scenario.timing.duration_s), demuxed)
    ours = [row for row in costs["streams"] if row["pid"] in {stream.pid for stream in signer}]
    programme_row = [row for row in costs["streams"] if row["pid"] == demuxed.streams[0].pid]
    probed = None
    if shutil.which("ffprobe"):
        result = subprocess.run(["ffprobe", "-v", "error", "-show_entries", "stream=index,codec_name,codec_type",
                                 "-of", "csv=p=0", str(path)], capture_output=True, text=True, timeout=60)
        if not result.returncode:                    # ffprobe lists each stream under its program too: once each
            listed = dict(line.strip().split(",", 1) for line in result.stdout.splitlines() if line.count(",") >= 2)
            probed = [listed[index] for index in sorted(listed, key=int)]
    return {"kind": "transport stream", "solution": description.solution, "codec": description.codec,
            "clip": scenario.name, "fps": description.fps, "duration_s": scenario.timing.duration_s,
            "file": f"ts/{path.name}", "ts_bytes": len(data),
            "signer_payload_kbps": sum(row["payload_kbps"] for row in ours),
            "signer_overhead_kbps": sum(row["overhead_kbps"] for row in ours),
            "stream_kbps": kbps(8 * delivery.sent.media_bytes, scenario.timing.duration_s),
            "programme_payload_kbps": programme_row[0]["payload_kbps"] if programme_row else None,
            "psi_kbps": costs["psi_kbps"], "pcr_kbps": costs["pcr_kbps"], "total_kbps": costs["total_kbps"],
            "demuxed_intact": intact, "ffprobe_streams": probed}


# ------------------------------------------------------------------------------------------------------------
# `signcast send` and `signcast receive`: the two ends in separate processes

SEND_SOLUTIONS = (Solution.NSV, Solution.SSV, Solution.FBA, Solution.BBA)   # `send` renders the avatar: no natural video to segment


@dataclass(frozen=True)
class SendSettings:
    """One sender: what is sent (a --codecs item of `live`: a parameter codec, NSV's or SSV's video codec) and q,
    the signing (language, word or pose), the rendered size (NSV and SSV send the render), the receiver's address,
    and the relay's loss (loss_rate: fraction of datagrams 0..1, burst, jitter_ms, reorder, seed; no relay when all are 0)."""
    codec: str
    q: int | None                      # None: the codec's default (DEFAULT_VIDEO_Q, or DEFAULT_PARAM_Q)
    destination: tuple[str, int]
    language: str = "ase"
    word: str = "HELLO"
    pose: str | None = None
    size: tuple[int, int] = (352, 288)
    refresh: int = 25
    units: str = "frame"
    shape_gop: int = 1
    loss_rate: float = 0.0
    burst: float = 1.0
    jitter_ms: float = 0.0
    reorder: float = 0.0
    seed: int = 1
    backend: str = "auto"

    def resolved_q(self) -> int:
        """q as given, else the item's own :Q, else the codec's default (DEFAULT_VIDEO_Q, DEFAULT_PARAM_Q)."""
        solution, codec, item_q = parse_send(self.codec)
        if self.q is not None:
            return self.q
        if item_q is not None:
            return item_q
        return DEFAULT_VIDEO_Q[codec] if solution in VIDEO_SOLUTIONS else DEFAULT_PARAM_Q

    def network(self) -> LiveSettings:
        solution, codec, item_q = parse_send(self.codec)
        video = solution in VIDEO_SOLUTIONS
        q = self.q if self.q is not None else item_q
        return LiveSettings(codecs=(self.codec,), loss_rates=(self.loss_rate,), burst=self.burst,
                            jitter_ms=self.jitter_ms, reorder=self.reorder, refresh=self.refresh, units=self.units,
                            seed=self.seed,
                            shape_gop=self.shape_gop, language=self.language, word=self.word, pose=self.pose,
                            size=self.size, video_q=q if video else None,
                            param_q=DEFAULT_PARAM_Q if video or q is None else q,
                            backend=self.backend)


def check_send(settings: SendSettings) -> None:
    solution = parse_send(settings.codec)[0]
    if solution not in SEND_SOLUTIONS:
        raise SigncastError(f"`send` renders the avatar and has no natural video to cut into objects: send "
                            f"{', '.join(SEND_SOLUTIONS)} (signcast live measures {solution} on the demo's scenario)")
    check(settings.network())


def _signing(settings: SendSettings, solution: str, progress: bool):
    """(name, motion, rendered frames and labels, or None and None) of what `send` sends."""
    from media import fingerspelling
    if settings.pose is not None:
        from media.retarget import retarget
        motion = retarget(shared.read_pose(settings.pose), load_avatar().skeleton).motion
        name = Path(settings.pose).stem
    else:
        motion = fingerspelling.fingerspell(settings.language, settings.word, fps=shared.DISPLAY_FPS)
        name = f"{settings.language}-{settings.word}"
    frames = labels = None
    if solution in VIDEO_SOLUTIONS:
        renderer = AvatarRenderer(load_avatar(), RenderSettings(width=settings.size[0], height=settings.size[1],
                                                                backend=settings.backend))
        frames, labels = shared.render_frames(renderer, motion, "render", progress)
    return name, motion, frames, labels


def run_send(settings: SendSettings, *, progress: bool = True) -> dict:
    """Sends one session to settings.destination (through a lossy relay in this process when loss is set);
    returns a summary of what was sent."""
    check_send(settings)
    settings = dataclasses.replace(settings, q=settings.resolved_q())
    solution, codec, _ = parse_send(settings.codec)
    name, motion, frames, labels = _signing(settings, solution, progress)
    payload, source = endpoints.source_for(solution, codec, settings.q, frames=frames, labels=labels, motion=motion,
                                           fps=motion.fps, refresh=settings.refresh, shape_gop=settings.shape_gop,
                                           units=settings.units)
    details = ({"refresh": settings.refresh, "units": settings.units} if Solution(solution).mpeg4_parameters else
               {"shape_gop": settings.shape_gop} if solution != "NSV" else {})
    description = SessionDescription(solution, codec, payload, settings.q, motion.fps, motion.n_frames,
                                     *settings.size, clip=name, details=details)
    network = settings.network()
    lossy = settings.loss_rate > 0 or settings.jitter_ms > 0 or settings.reorder > 0
    if lossy:
        relay = LossyRelay(settings.destination, network_model(network, settings.loss_rate, settings.seed))
        with relay:
            sent = send(description, source, settings.destination, relay=relay)
        dropped = relay.counts.dropped
    else:
        sent = send(description, source, settings.destination)
        dropped = 0
    duration = motion.n_frames / motion.fps
    return {"clip": name, "solution": solution, "codec": codec, "q": settings.q, "frames": motion.n_frames,
            "fps": motion.fps, "packets": sent.packets, "dropped_by_relay": dropped,
            "kbps": kbps(8 * sent.media_bytes, duration),
            "delivered_kbps": kbps(8 * (sent.rtp_bytes + IP_UDP_BYTES * sent.packets), duration),
            "late_frames": sent.late_frames}


def run_receive(port: int, out_dir: Path, *, timeout_s: float = 60.0, backend: str = "auto",
                host: str = "127.0.0.1", on_listening: Callable[[int], object] | None = None,
                listener: Listener | None = None) -> dict:
    """Receives one session on port (TCP control and UDP media), or on `listener` already bound, writes what
    was shown to out_dir/shown.mkv (lossless FFV1) and a delivery record to out_dir/records.jsonl; returns the
    record. The sink (decoder, renderer) is built and warmed up before the sender is answered READY."""
    from media.video_io import write_video
    renderer_for = shared.renderers(backend)
    listener = listener or Listener(host, port)

    def sink_for(description):
        sink = endpoints.sink_for(description, renderer_for)
        endpoints.warm_up_sink(sink)
        return sink

    try:
        if on_listening is not None:
            on_listening(listener.port)
        got = receive(listener, sink_for, timeout_s=timeout_s)
    finally:
        listener.close()
    d = got.description
    duration = d.n_frames / d.fps
    frames_lost = int((~got.received).sum())
    record = make_record(d.solution, d.clip, d.codec, d.q, d.fps, d.width, d.height, 0, duration, sweep="receive",
                         frames_lost=frames_lost,
                         frames_concealed=frames_lost + _damaged_frames(got.sink_stats),
                         received_kbps=kbps(8 * (got.rtp_bytes + IP_UDP_BYTES * got.packets), duration),
                         refresh=d.details.get("refresh") if isinstance(d.details, dict) else None,
                         **delivery_fields(got, None, None))
    record["bits"] = None
    record["kbps"] = None
    write_video(out_dir / "shown.mkv", got.shown, d.fps)
    write_records(out_dir / "records.jsonl", [record])
    return record
