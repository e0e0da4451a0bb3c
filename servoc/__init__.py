"""servoc: compiles .servo frame programs into cycle-exact 8051 firmware."""

__version__ = "0.1.0"
