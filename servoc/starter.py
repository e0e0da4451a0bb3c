"""The commented starter program that `servoc init NAME` writes."""

STARTER = """\
# {name}.servo: a first servoc program.
# Lint it:     servoc lint {name}.servo
# See it:      servoc plan {name}.servo
# Build it:    servoc compile {name}.servo -o {name}.hex
# Prove it:    servoc verify {name}.servo
#
# Positions: 90deg (0.74 deg per step), 1500us (500 us + 8 us x N), or a raw N (0..250).
# Times: us, ms, s. Without `frame`, servoc picks the shortest period the firmware
# sustains (never below 5.3 ms).

target at89c52 clock 12MHz

# One servo per pin, P0.0 to P2.7. Options: speed DUR/ANGLE, trim N, limit A..B, reverse.
servo base     = P1.0
servo shoulder = P1.1 limit 30deg..150deg
servo elbow    = P1.2 reverse
servo gripper  = P1.3 speed 0.15s/60deg

group arm = shoulder, elbow

pose rest  {{ base: 90deg, arm: 90deg, gripper: 1500us }}
pose reach = rest with {{ shoulder: 130deg, elbow: 60deg }}
pose grab  = reach with {{ gripper: 60deg }}
pose left  = grab with {{ base: 30deg }}
pose right = grab with {{ base: 150deg }}

# Power-up: the first frames hold the servos at `rest`, switched on 100 ms apart
# so that they do not all draw their starting current at once.
home rest
stagger 100ms

sequence pick {{
  move reach in 500ms ease in-out
  move grab in 200ms
  hold 300ms
}}

main {{
  loop {{
    play pick
    move left in 800ms ease in-out
    move right                      # as fast as the slowest servo allows
    move rest in 600ms
  }}
}}
"""


def starter(name: str) -> str:
    return STARTER.format(name=name)
