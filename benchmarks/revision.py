"""Another revision of this repository, beside this tree: checked out in a temporary worktree, its
servoc run in a fresh interpreter (`compile_time.py` times builds with it; `reported_at` gives the
shortest period it reports for each program: the benchmark table's "before" column).

    .venv/bin/python benchmarks/revision.py REV FILE.servo ...     # the shortest P REV reports for each
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
from contextlib import contextmanager
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

# Python run in a fresh interpreter with the side's tree (sys.argv[1]) first on the path, and its
# templates and grammar too (an editable install maps servoc.firmware_templates to its own tree)
CHILD_HEAD = """
import json, sys
sys.path.insert(0, sys.argv[1])
import servoc
servoc.__path__.append(sys.argv[1])
from importlib import resources
assert str(resources.files("servoc.firmware_templates")).startswith(sys.argv[1]), "another tree's templates"
"""

# each program of the JSON list on standard input ([text, again]): the shortest period that
# revision's servoc reports for it (Plan.min_period_us), planned again at that period where `again`
# (as engine_terms.terms does: a record's F can differ at 20 ms), or the error codes
_SHORTEST = CHILD_HEAD + """
import re
from servoc import api
from servoc.diagnostics import Reporter
from servoc.source import SourceFile

def shortest(text):
    source = SourceFile("before.servo", text)
    reporter = Reporter(source)
    plan = api.front_end(source, reporter).plan
    errors = sorted({d.code for d in reporter.diagnostics if d.is_error})
    return plan.min_period_us if plan is not None and not errors else errors

out = []
for text, again in json.loads(sys.stdin.read()):
    got = shortest(text)
    if again and isinstance(got, int):
        got = shortest(re.sub(r"^frame .*$", f"frame {got}us", text, count=1, flags=re.M))
    out.append(got)
print(json.dumps(out))
"""


@contextmanager
def worktree(rev: str):
    """REV checked out in a temporary worktree (removed again after), its path."""
    with tempfile.TemporaryDirectory() as tmp:
        other = Path(tmp) / "other"
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", "-q", str(other), rev], check=True)
        try:
            yield other
        finally:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(other)], check=True)


def child(code: str, tree: Path, *args: str, stdin: str | None = None) -> str:
    """The last line `code` prints, run with `tree`'s servoc (CHILD_HEAD first)."""
    done = subprocess.run([sys.executable, "-c", code, str(tree), *args], input=stdin, capture_output=True,
                          text=True, check=True, cwd=tree)
    return done.stdout.strip().splitlines()[-1]


def reported_at(rev: str, programs: list[tuple[str, bool]]) -> list[int | list[str]]:
    """The shortest period (us) REV's servoc reports for each program ([text, again]: planned
    again at that period), or the error codes it gives."""
    if not programs:
        return []
    with worktree(rev) as tree:
        return json.loads(child(_SHORTEST, tree, stdin=json.dumps(programs)))


def main(argv: list[str]) -> int:
    rev, *files = argv
    for path, got in zip(files, reported_at(rev, [(Path(f).read_text(encoding="utf-8"), False) for f in files])):
        print(f"{path}: {got}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
