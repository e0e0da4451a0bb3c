"""The lint rules, one module each (its code and severity in its `@rule`); importing this
package registers them, in this order."""

from . import (  # noqa: F401
    infeasible_speed, eased_overspeed,
    off_grid_width, inexact_angle,
    period_too_short, period_too_long, short_gap, short_hold, empty_loop, too_long,
    unused, unreachable, duplicate_event,
    no_home, level_in_loop, until_no_frame,
    p0_pull_up,
    host_ram, host_takes_bytes, host_play_waits, too_deep,
    firmware_limit,
)
