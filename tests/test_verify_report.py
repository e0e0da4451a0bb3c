"""What `servoc verify --events` says happened: each select reached and what it took, the events
no select took, a run long enough to check every consequence of the last event, and a span it
states plainly when it cannot run the whole program."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from servoc import verify
from servoc.cli import main

pytestmark = pytest.mark.toolchain

ROOT = Path(__file__).resolve().parent.parent

PAN = """\
input button = P3.2
servo pan = P1.0
pose left { pan: 60deg }
pose right { pan: 120deg }
main {
  move left
  loop {
    wait button
    move right in 1s
    move left in 1s
  }
}
"""


def verify_json(tmp_path, capsys, text: str, events: str, *more: str) -> tuple[int, dict]:
    prog = tmp_path / "p.servo"
    prog.write_text(text)
    args = ["verify", "--format", "json", str(prog)]
    if events is not None:
        ev = tmp_path / "p.events"
        ev.write_text(events)
        args += ["--events", str(ev)]
    rc = main(args + list(more))
    return rc, json.loads(capsys.readouterr().out)


def test_a_press_no_select_saw_is_a_warning_and_the_branches_are_listed(tmp_path, capsys):
    # pressed at 0.3 s: taken; pressed again at 0.8 s while the arm moves right (no select waits): unseen
    rc, data = verify_json(tmp_path, capsys, PAN, "300ms button active\n350ms button inactive\n"
                                                  "800ms button active\n900ms button inactive\n")
    assert rc == 0 and data["ok"]
    (taken,) = data["selects"]
    assert taken["branch"] == "on button" and taken["line"] == 8 and taken["waited_frames"] > 0
    assert "`button` active at 0.3000 s" in taken["event"]
    assert 0 < taken["time_us"] - 300_000 <= 2 * 5300
    assert any(w.startswith("`button` active from 0.8000 s") for w in data["warnings"]), data["warnings"]


def test_every_reply_due_is_checked(tmp_path, capsys):
    # the serial arm's last commands come at 4 s; the last reply ("H") is due past 7 s
    text = (ROOT / "examples/serial_arm.servo").read_text(encoding="utf-8")
    events = (ROOT / "examples/events/serial_arm.events").read_text(encoding="utf-8")
    rc, data = verify_json(tmp_path, capsys, text, events)
    assert rc == 0 and data["ok"] and data["bytes_sent"] == 7 and data["not_checked"] == []
    assert [s["branch"] for s in data["selects"]] == ['on "l"', 'on "p"', 'on "r"', 'on "d"', 'on "w"', 'on "h"']
    assert [s["waited_frames"] == 0 for s in data["selects"]][3:] == [True, True, True]    # queued: no frame of its own
    assert any('byte "x"' in w for w in data["warnings"])


def test_an_event_past_the_run_is_a_usage_error_naming_its_line(tmp_path, capsys, monkeypatch):
    prog = tmp_path / "p.servo"
    prog.write_text(PAN)
    ev = tmp_path / "p.events"
    ev.write_text("# a press, then one far past the run\n300ms button active\n100000s button inactive\n")
    assert main(["verify", str(prog), "--events", str(ev), "--frames", "50"]) == 2
    err = capsys.readouterr().err
    assert "line 2:" in err and "after the 50 frames verify runs" in err and "--frames" in err, err
    monkeypatch.setattr(verify, "MAX_SPAN_CYCLES", 5_000_000)        # the default is 60 s at 12 MHz
    assert main(["verify", str(prog), "--events", str(ev)]) == 2
    err = capsys.readouterr().err
    assert "line 3:" in err and "verify runs at most" in err, err


def test_a_long_program_is_checked_over_a_stated_span(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(verify, "MAX_SPAN_CYCLES", 3_000_000)        # the default is 60 s at 12 MHz
    text = "frame 65.535ms\nservo arm = P1.0\npose a { arm: 100 }\nmain { move a; hold 1300s }\n"
    rc, data = verify_json(tmp_path, capsys, text, None)
    assert rc == 0 and data["ok"]
    assert data["frames"] == 3_000_000 // 65535 - 2
    assert len(data["not_checked"]) == 1 and "verify checks the first" in data["not_checked"][0]
