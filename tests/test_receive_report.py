"""`signcast report` on what `signcast receive` wrote: a page of what arrived, not "no measured points" (issue 38).

A real session: `run_send` sends the avatar's letter as FBA over RTP/UDP on the loopback to `run_receive`, which
writes records.jsonl; the report command then reads those records."""
from __future__ import annotations

import threading

from pipeline.cli import main
from pipeline.live.session import Listener
from pipeline.studies import live


def test_report_of_a_received_session_shows_what_arrived(tmp_path, capsys):
    listener = Listener("127.0.0.1", 0)
    got: dict = {}
    receiver = threading.Thread(target=lambda: got.update(
        record=live.run_receive(listener.port, tmp_path, timeout_s=60, backend="numpy", listener=listener)))
    receiver.start()
    live.run_send(live.SendSettings(codec="fba-pred", q=None, destination=("127.0.0.1", listener.port),
                                    word="A", size=(96, 80), backend="numpy"), progress=False)
    receiver.join(120)
    assert not receiver.is_alive() and got["record"]["frames_lost"] == 0

    assert main(["report", str(tmp_path / "records.jsonl"), "-o", str(tmp_path / "report.html")]) == 0
    page = (tmp_path / "report.html").read_text()
    assert "signcast receive: what arrived" in page and 'data-table="received sessions"' in page
    row = page.split('data-table="received sessions"')[1].split("</tbody>")[0]
    frames = round(got["record"]["duration_s"] * got["record"]["fps"])
    assert "<td>FBA</td><td>fba-pred</td>" in row and f"<td>{got['record']['packets_received']}</td>" in row
    assert got["record"]["packets_received"] >= frames
    assert "no measured points" not in capsys.readouterr().err
