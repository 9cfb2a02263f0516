"""What a session sends once, before its first frame (issue 35, item 7: equal terms), for `signcast compare`:

- the avatar the terminal needs to re-render FBA/BBA (media.avatar.DEFAULT_AVATAR, an .npz whose arrays are
  already deflated: it is charged as stored, its size beside zlib's best on it to show that it does not shrink);
- the session description, as `signcast live` sends it on its control connection (pipeline.live.session:
  SessionDescription.to_line, one JSON line), here with every field at its widest value (a 19-digit capture
  clock, 10-digit SSRCs, 5-digit first sequence numbers) and one RTP stream per sent object.

`session_costs(scenario, settings...)` -> the run record's "session_costs" field: {"avatar_bytes",
"avatar_zlib_bytes", "avatar_file", "descriptions": {"solution codec": bytes}}. The report charges the parameter
streams the avatar plus their description, video its description, once per session, and gives the duration of
signing after which parameters cost less in all (comparisons.reports.headline.break_even_s).
"""
from __future__ import annotations

import zlib
from pathlib import Path

# the RTP payload format each codec would travel in (libsvtav1 is not sent live: a payload name of the same length)
_PAYLOADS = {"mpeg4": "mp4v", "libx264": "h264", "libsvtav1": "av1"}
# the objects each video solution sends as streams (comparisons.video.objects)
_STREAMS = {"NSV": 1, "NSV-ROI": 1, "NSV2O": 2, "NSV3O": 3, "NSV3O+C": 4, "SSV": 3}


def avatar_cost(path: str | Path | None = None) -> dict:
    """{"avatar_file": name, "avatar_bytes": its size as stored, "avatar_zlib_bytes": zlib level 9 on it}."""
    from media.avatar import DEFAULT_AVATAR
    path = Path(path or DEFAULT_AVATAR)
    data = path.read_bytes()
    return {"avatar_file": path.name, "avatar_bytes": len(data), "avatar_zlib_bytes": len(zlib.compress(data, 9))}


def description_bytes(solution: str, codec: str, q: int, fps: float, n_frames: int, width: int, height: int,
                      clip: str, details: dict | None = None) -> int:
    """The bytes of the session description line `signcast live` would send for this solution and codec."""
    from media.domain import Solution
    from pipeline.live.session import SessionDescription
    parameters = Solution(solution).mpeg4_parameters
    payload = "units" if parameters else ("objects" if _STREAMS.get(solution, 1) > 1 else _PAYLOADS.get(codec, "mp4v"))
    streams = 1 if parameters else _STREAMS.get(solution, 1)
    description = SessionDescription(solution, codec, payload, int(q), float(fps), int(n_frames), int(width),
                                     int(height), clip=clip, t0_ns=10 ** 18, details=dict(details or {}))
    description.streams = [{"name": f"object{k}", "payload": "units" if parameters else _PAYLOADS.get(codec, "mp4v"),
                            "ssrc": 4_000_000_000 + k, "first_sequence": 60_000 + k} for k in range(streams)]
    return len(description.to_line())


def session_costs(series: list[tuple[str, str]], *, fps: float, n_frames: int, size: tuple[int, int], clip: str,
                  refresh: int | None = None) -> dict:
    """The run record's "session_costs": the avatar's download and each (solution, codec)'s description bytes."""
    from media.domain import Solution
    width, height = size
    descriptions = {}
    for solution, codec in series:
        parameters = Solution(solution).mpeg4_parameters
        details = {"refresh": refresh, "units": "period"} if parameters and refresh else {}
        descriptions[f"{solution} {codec}"] = description_bytes(solution, codec, 31, fps, n_frames, width, height,
                                                                clip, details)
    return {**avatar_cost(), "descriptions": descriptions}
