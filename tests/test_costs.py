"""The frame-cost model in servoc/costs.py against ucsim: safe, and not wasteful.

The worst-case stress programs of benchmarks/stress.py (every servo moving
every frame, a new move record every frame, nested repeats ending together)
must verify exactly at the model's minimum period, and fail well before it
is reached from below, so the model is an upper bound that stays close.
"""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))

import stress  # noqa: E402

from servoc import api, costs  # noqa: E402
from servoc.diagnostics import Reporter  # noqa: E402
from servoc.source import SourceFile  # noqa: E402

pytestmark = pytest.mark.toolchain


def model_minimum(ports, per_port, runtime_f=False, depth=None):
    text = stress.stress_source(ports, per_port, 20000, runtime_f, depth)
    source = SourceFile("stress.servo", text)
    reporter = Reporter(source)
    plan = api.plan(api.check(api.parse(source, reporter), reporter), reporter)
    assert not reporter.has_errors
    return plan.min_period_us


@pytest.mark.parametrize("ports, per_port, runtime_f, depth", [
    (1, 8, False, None),
    (3, 8, False, None),
    (2, 3, True, None),
    (1, 2, False, 8),
])
def test_model_minimum_is_exact_and_close(ports, per_port, runtime_f, depth):
    p_min = model_minimum(ports, per_port, runtime_f, depth)
    assert stress.exact_at(ports, per_port, p_min, runtime_f, frames=300, depth=depth)
    # not wasteful: 8% below the model's own between-frame budget already breaks the program
    budget = p_min - costs.PORT_CYCLES * ports
    assert not stress.exact_at(ports, per_port, p_min - max(60, budget * 3 // 10), runtime_f, frames=300, depth=depth)


def test_port_routine_length_is_what_verify_assumes():
    # pulse.asm.j2 is laid out so one port takes PORT_CYCLES; verify aligns ports by it
    assert costs.PORT_CYCLES == 1 + costs.HEAD_CYCLES - 1 + 8 * (costs.FINAL_N + 1) + 1 == 2510
