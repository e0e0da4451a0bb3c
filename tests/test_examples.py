"""Every program in examples/: it lints without an error, compiles, and its firmware, run in
ucsim, sends exactly the planned pulses."""

from __future__ import annotations

from pathlib import Path

import pytest

from servoc import api
from servoc.plan import verify_frames

EXAMPLES = sorted((Path(__file__).parent.parent / "examples").glob("*.servo"))
FRAMES = 300        # per example: enough for every move of a pass or two, and quick in ucsim


def test_there_are_examples():
    assert len(EXAMPLES) >= 3


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_lints_clean(path: Path):
    source, reporter = api.load_source(str(path))
    fe = api.front_end(source, reporter)
    assert fe.plan is not None and not reporter.has_errors, [(d.code, d.message) for d in reporter.diagnostics]


@pytest.mark.toolchain
@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_compiles_and_verifies(path: Path):
    source, reporter = api.load_source(str(path))
    fe, firmware = api.build(source, reporter)
    assert firmware is not None, [(d.code, d.message) for d in reporter.diagnostics]
    frames = min(FRAMES, verify_frames(fe.plan))
    report = api.verify(fe.plan, firmware, frames)
    assert report.ok and report.frames == frames, report.summary()
