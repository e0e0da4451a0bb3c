"""Import: motion made in other tools -> .servo text (see `servoc.imports.write`).

One reader per format, each `read(data: bytes, path: str, options) -> Keyframes`;
`detect` picks the reader from the content when the user does not name it.
"""
