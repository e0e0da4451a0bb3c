"""When a move asks a servo for more than its top speed: the one rule of the linter and the plot.

Two questions, both answered in exact arithmetic on the plan's move instances
(`Plan.moves`, one per move and context) and the language's curve
(`plan.frame_value`, the N the spec defines for frame k of F):

* the move instance is too fast for the servo (lint `infeasible-speed`, an error):
  |delta| x t_DAV > F x P, it cannot get there in time (`infeasible`);
* a frame of an eased move asks more than top speed (lint `eased-overspeed`, a
  warning): its step from the frame before, |N_k - N_(k-1)| x t_DAV > P
  (`step_too_fast`), for the curve's steepest frame (`peak_step`).

A linear move that is not infeasible is never over speed: its frames step by
floor or ceil of |delta| / F, and a step one N above the average is rounding,
not a demand the servo cannot follow. `frames_over` answers, frame by frame,
what the plot draws in red: every moving frame of an infeasible instance, and
the eased frames whose step is too fast; `servoc plan --plot` and the two lint rules
call only the functions here.
"""

from __future__ import annotations

from fractions import Fraction
from functools import lru_cache

from .plan import frame_value

from .steps import MoveInstance, Plan, ServoMotion

__all__ = ["curve_steps", "excess_us", "frames_over", "infeasible", "motion_frames_over", "peak_step",
           "step_too_fast", "t_dav_of", "too_fast"]


def t_dav_of(plan: Plan, channel: int) -> Fraction:
    """t_DAV of a channel's servo, in us per DAV."""
    return plan.class_t_dav_us[plan.channels[channel].speed_class]


def excess_us(delta: int, frames: int, t_dav_us: Fraction, period_us: int) -> Fraction:
    """|delta| x t_DAV - F x P: how much longer than the move the servo needs (> 0: too fast)."""
    return abs(delta) * Fraction(t_dav_us) - frames * period_us


def infeasible(delta: int, frames: int, t_dav_us: Fraction, period_us: int) -> bool:
    """|delta| x t_DAV > F x P: the servo cannot travel delta in F frames."""
    return excess_us(delta, frames, t_dav_us, period_us) > 0


def step_too_fast(step: int, t_dav_us: Fraction, period_us: int) -> bool:
    """|step| x t_DAV > P: one frame's step is more than the servo travels in a frame."""
    return abs(step) * Fraction(t_dav_us) > period_us


def curve_steps(n0: int, n1: int, frames: int, ease: str) -> list[int]:
    """The curve's step into each frame k = 1..F, N_k - N_(k-1) (frame 0 is n0)."""
    prev, steps = n0, []
    for k in range(1, frames + 1):
        cur = frame_value(n0, n1, k, frames, ease)
        steps.append(cur - prev)
        prev = cur
    return steps


@lru_cache(maxsize=1 << 16)
def peak_step(n0: int, n1: int, frames: int, ease: str) -> int:
    """The largest |step| in DAV between two frames of a move (frame 0 is n0); the same curves
    come back in many move instances (a move in every state it can start from)."""
    if n0 == n1:
        return 0
    if 2 * abs(n1 - n0) < frames:
        # e' <= 2 for every easing, so no frame moves 1 DAV or more before rounding,
        # hence at most 1 after; and the steps add up to |delta| > 0.
        return 1
    return max(abs(s) for s in curve_steps(n0, n1, frames, ease))


def frames_over(n0: int | None, n1: int, frames: int, ease: str, t_dav_us: Fraction,
                period_us: int) -> list[bool]:
    """Per frame k = 1..F of a move from n0 to n1: is the servo asked for more than its top speed?

    Every frame that moves, when the move is infeasible; for a feasible eased move, the frames
    whose step is too fast; never for a feasible linear move, nor for a servo set at once (n0 None)."""
    if n0 is None or n0 == n1:
        return [False] * frames
    if infeasible(n1 - n0, frames, t_dav_us, period_us):
        return [s != 0 for s in curve_steps(n0, n1, frames, ease)]
    if ease == "linear" or not step_too_fast(peak_step(n0, n1, frames, ease), t_dav_us, period_us):
        return [False] * frames
    return [step_too_fast(s, t_dav_us, period_us) for s in curve_steps(n0, n1, frames, ease)]


def motion_frames_over(plan: Plan, inst: MoveInstance, motion: ServoMotion) -> list[bool]:
    """`frames_over` for one servo of a move instance of the plan."""
    return frames_over(motion.n0, motion.n1, inst.frames, inst.step.ease, t_dav_of(plan, motion.channel),
                       plan.period_us)


def too_fast(plan: Plan) -> dict[int, tuple[Fraction, MoveInstance, int]]:
    """Moves that ask a servo for |delta| x t_DAV > F x P, by id of their step:
    (the largest excess in us, the instance, the channel) of the worst context."""
    worst: dict[int, tuple[Fraction, MoveInstance, int]] = {}
    # t_DAV = num / den per channel: the test in integers, the excess only for moves that fail it
    rates = [(t.numerator, t.denominator) for t in (t_dav_of(plan, c) for c in range(len(plan.channels)))]
    for inst in plan.moves:
        budget = inst.frames * plan.period_us
        for m in inst.motions:
            if m.n0 is None:
                continue
            num, den = rates[m.channel]
            if abs(m.n1 - m.n0) * num <= budget * den:
                continue
            excess = excess_us(m.delta, inst.frames, t_dav_of(plan, m.channel), plan.period_us)
            if id(inst.step) not in worst or excess > worst[id(inst.step)][0]:
                worst[id(inst.step)] = (excess, inst, m.channel)
    return worst
