"""The firmware's own cost per frame, in machine cycles (1 us at 12 MHz).

This is the one place the front end learns what the generated firmware
needs: the shortest frame period it sustains for the ports in use. The
figures are properties of `firmware_templates/`; `tests/test_costs.py`
measures them in ucsim and fails when they drift.
"""

from __future__ import annotations

from .units import DEFAULT_PERIOD_FLOOR_US

# Cycles from a port's rise to the end of its routine: the longest pulse
# (N = 250 ends at 2500) plus the cycles after the last edge.
PORT_CYCLES = 2520
# Cycles a frame spends outside the port routines in the worst case:
# timer wait exit, the next frame's interpolation, sort and differencing.
FRAME_OVERHEAD_CYCLES = 1400


def min_period_us(port_count: int) -> int:
    """The shortest frame period the firmware sustains with `port_count` ports in use."""
    if port_count == 0:
        return FRAME_OVERHEAD_CYCLES
    return FRAME_OVERHEAD_CYCLES + PORT_CYCLES * port_count


def default_period_us(port_count: int) -> int:
    """The spec's default P: the shortest sustainable period, never below 5.3 ms."""
    return max(DEFAULT_PERIOD_FLOOR_US, min_period_us(port_count))
