"""Import: motion made in other tools -> .servo text (see `servoc.imports.write`).

One reader per format (`maestro`, `blender`, `bottango`, `csvfile`), each with
`read(data: bytes, path: str, options) -> Keyframes` and `sniff(data, path) -> bool`;
`servoc.api.read_motion` asks each `sniff` in turn when the user does not name the format.
"""
