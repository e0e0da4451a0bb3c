"""Parsing: `SourceFile` text -> `nodes.Program`.

Input: the decoded text of one .servo file. Output: a `nodes.Program` (see
`servoc.nodes` for its invariants), or None after reporting exactly one
`syntax-error` diagnostic.

The grammar is `grammar/servo.lark`, parsed by lark's LALR(1) parser with its
contextual lexer; the parser is built once. Keywords are reserved: a postlexer
turns a NAME token spelled like a keyword into that keyword, so `servo main =`
fails where a name was expected. The words of SOFT_WORDS (`host`, `channel`) are
written as literals in the grammar but are no keywords: the contextual lexer
reads them as the word only where the grammar expects it, a NAME elsewhere.
Parse errors are described in the words of the language ("a pose name", "a
position such as `90deg`"), never with lark's terminal names. `parse` never raises, whatever the input.
"""

from __future__ import annotations

import difflib
import re
import unicodedata
from fractions import Fraction
from functools import lru_cache
from typing import Iterable, Iterator

from lark import Lark, Token
from lark.exceptions import UnexpectedInput, UnexpectedToken
from lark.lexer import PatternStr

from . import nodes
from .diagnostics import Reporter
from .resources import grammar_text
from .source import SourceFile, Span

# More `{` open at once than this is refused: a select's braces count with
# its blocks', so 100 levels of blocks fit even with a select at each. This
# keeps every later recursive pass, such as dataclass equality, well inside
# Python's recursion limit.
MAX_NESTING = 200
# More digits than this in one number is refused before converting it.
MAX_DIGITS = 60

_NAME_RE = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
# Words the grammar writes as literals that are nevertheless no keywords: the statement `host`
# and the servo option `channel` (a pose may be called `host`, a servo `channel`).
SOFT_WORDS = frozenset({"host", "channel"})
_MICRO = ("\u00b5", "\u03bc")


class _Problem(Exception):
    """A syntax problem found while building nodes (e.g. a number too long)."""

    def __init__(self, message: str, span: Span, help: str = "") -> None:
        super().__init__(message)
        self.message, self.span, self.help = message, span, help


class _KeywordPostLex:
    """Turns NAME tokens spelled like a keyword into the keyword's token.

    lark's contextual lexer only recognises a keyword where the parser can
    accept it; elsewhere `main` would pass as a NAME. NAME is also lexed in
    every parser state (`always_accept`), so that `mainloop` is never split
    into `main` + `loop` where only keywords fit; so is PIN, so that a pin in
    the wrong place is reported as `P1.0`, not as `P1`.

    It also refuses more than MAX_NESTING braces open at once, before the
    parser builds anything that deep.
    """

    always_accept = ("NAME", "PIN")

    def __init__(self) -> None:
        self.keywords: dict[str, str] = {}

    def process(self, stream: Iterable[Token]) -> Iterator[Token]:
        keywords = self.keywords
        depth = 0
        for tok in stream:
            kind = tok.type
            if kind == "NAME":
                if tok.value in keywords:
                    tok = Token.new_borrow_pos(keywords[tok.value], tok.value, tok)
            elif kind == "LBRACE":
                depth += 1
                if depth > MAX_NESTING:
                    raise _Problem(f"blocks are nested too deeply: more than {MAX_NESTING} `{{` open at once",
                                   Span(tok.start_pos, tok.end_pos),
                                   help="split the program into sequences and `play` them")
            elif kind == "RBRACE":
                depth -= 1
            yield tok


@lru_cache(maxsize=None)
def _parser() -> Lark:
    postlex = _KeywordPostLex()
    parser = Lark(grammar_text(), parser="lalr", lexer="contextual", postlex=postlex,
                  transformer=_Builder(), maybe_placeholders=False)
    for term in parser.terminals:
        if (isinstance(term.pattern, PatternStr) and _NAME_RE.match(term.pattern.value)
                and term.pattern.value not in SOFT_WORDS):
            postlex.keywords[term.pattern.value] = term.name
    return parser


def keywords() -> frozenset[str]:
    """The reserved words of the language."""
    return frozenset(_parser().options.postlex.keywords)


# ---- parse ------------------------------------------------------------------

def parse(source: SourceFile, reporter: Reporter) -> nodes.Program | None:
    """Parse one file; on a syntax error report it once and return None.

    The nodes are built as lark parses, so the first problem in the file is
    the one reported, whether the grammar or a number finds it.
    """
    text = source.text
    try:
        return _parser().parse(text)
    except UnexpectedInput as exc:
        try:
            message, span, help_ = _describe(exc, text)
        except Exception:  # describing must never turn into a traceback
            pos = _pos_of(exc, text)
            message, span, help_ = "this text could not be read as .servo", Span(pos, pos + 1), ""
        reporter.error("syntax-error", message, span, help=help_)
        return None
    except _Problem as exc:
        reporter.error("syntax-error", exc.message, exc.span, help=exc.help)
        return None
    except RecursionError:
        reporter.error("syntax-error", "the program is nested too deeply to read", Span(0, 0),
                       help="split the program into sequences and `play` them")
        return None
    except Exception:
        reporter.error("syntax-error", "this program could not be read", Span(0, 0))
        return None


# ---- tree -> nodes ----------------------------------------------------------

def _tspan(tok: Token) -> Span:
    return Span(tok.start_pos, tok.end_pos)


def _name(tok: Token) -> nodes.Name:
    return nodes.Name(str(tok), _tspan(tok))


_NUMBER_RE = re.compile(r"([0-9]+)(?:\.([0-9]+))?(.*)\Z", re.S)


@lru_cache(maxsize=4096)
def _number(text: str) -> tuple[Fraction, str] | None:
    """A NUMBER token's value and unit (`µs` spelled `us`); None when it has too many digits."""
    whole, frac, unit = _NUMBER_RE.match(text).groups(default="")
    if len(whole.lstrip("0")) + len(frac) > MAX_DIGITS:
        return None
    if unit[:1] in _MICRO:
        unit = "u" + unit[1:]
    return Fraction(int(whole + frac), 10 ** len(frac)), unit


def _quantity(tok: Token, negative: bool = False, start: int | None = None) -> nodes.Quantity:
    span = Span(tok.start_pos if start is None else start, tok.end_pos)
    number = _number(tok.value)
    if number is None:
        raise _Problem(f"the number `{tok.value[:12]}...` has too many digits", span,
                       help=f"numbers may have at most {MAX_DIGITS} digits")
    value, unit = number
    return nodes.Quantity(-value if negative else value, unit, span)


def _end(node) -> int:
    """Where a child of a rule ends: a token, or a node with a span."""
    return node.end_pos if isinstance(node, Token) else node.span.end


def _rule_span(ch: list) -> Span:
    """A rule's span: its first token (a kept keyword or `{`) to its last child."""
    return Span(ch[0].start_pos, _end(ch[-1]))


class _Builder:
    """Builds `nodes` while lark parses (its inline transformer).

    Each method's grammar rule is above it, with the children it is given: the
    rules marked `!` keep their keywords and punctuation, which give the spans.
    """

    # start: _sep* (_item _sep+)* _item?
    def start(self, items):
        span = Span(items[0].span.start, items[-1].span.end) if items else Span(0, 0)
        return nodes.Program(tuple(items), span)

    # !frame_decl: "frame" NUMBER
    def frame_decl(self, ch):
        return nodes.FrameDecl(_quantity(ch[1]), _rule_span(ch))

    # !target_decl: "target" NAME ("clock" NUMBER)? (NAME NUMBER)?     the second NAME: `mode`
    def target_decl(self, ch):
        _, chip, *rest = ch
        clock = None
        if rest and rest[0].type == "CLOCK":
            clock = _quantity(rest[1])
            rest = rest[2:]
        mode = (_name(rest[0]), _quantity(rest[1])) if rest else None
        return nodes.TargetDecl(_name(chip), clock, _rule_span(ch), mode)

    # !input_decl: "input" NAME "=" PIN NAME?      the second NAME: `low` or `high`
    def input_decl(self, ch):
        _, name, _, pin, *level = ch
        return nodes.InputDecl(_name(name), nodes.Pin(str(pin), _tspan(pin)),
                               _name(level[0]) if level else None, _rule_span(ch))

    # !serial_decl: "serial" NUMBER
    def serial_decl(self, ch):
        return nodes.SerialDecl(_quantity(ch[1]), _rule_span(ch))

    # setting_decl: NAME (NAME | NUMBER)      the first NAME: `home` or `stagger`
    def setting_decl(self, ch):
        word, value = ch
        return nodes.SettingDecl(_name(word), _name(value) if value.type == "NAME" else _quantity(value),
                                 Span(word.start_pos, value.end_pos))

    # !servo_decl: "servo" NAME "=" PIN _servo_option*
    def servo_decl(self, ch):
        _, name, _, pin, *options = ch
        return nodes.ServoDecl(_name(name), nodes.Pin(str(pin), _tspan(pin)), tuple(options), _rule_span(ch))

    # !speed_option: "speed" NUMBER "/" NUMBER
    def speed_option(self, ch):
        return nodes.SpeedOption(_quantity(ch[1]), _quantity(ch[3]), _rule_span(ch))

    # !trim_option: "trim" SIGN? NUMBER
    def trim_option(self, ch):
        if len(ch) == 3:
            sign, num = ch[1], ch[2]
            return nodes.TrimOption(_quantity(num, sign == "-", sign.start_pos), _rule_span(ch))
        return nodes.TrimOption(_quantity(ch[1]), _rule_span(ch))

    # !limit_option: "limit" NUMBER ".." NUMBER
    def limit_option(self, ch):
        return nodes.LimitOption(_quantity(ch[1]), _quantity(ch[3]), _rule_span(ch))

    # !reverse_option: "reverse"
    def reverse_option(self, ch):
        return nodes.ReverseOption(_rule_span(ch))

    # !channel_option: "channel" NUMBER
    def channel_option(self, ch):
        return nodes.ChannelOption(_quantity(ch[1]), _rule_span(ch))

    # !group_decl: "group" NAME "=" NAME ("," _NL* NAME)*
    def group_decl(self, ch):
        members = tuple(_name(t) for t in ch[3:] if t.type == "NAME")
        return nodes.GroupDecl(_name(ch[1]), members, _rule_span(ch))

    # !pose_decl: "pose" NAME pose_body
    def pose_decl(self, ch):
        entries, end = ch[2]
        return nodes.PoseDecl(_name(ch[1]), None, entries, Span(ch[0].start_pos, end))

    # "pose" NAME "=" NAME "with" pose_body  -> pose_with_decl
    def pose_with_decl(self, ch):
        entries, end = ch[5]
        return nodes.PoseDecl(_name(ch[1]), _name(ch[3]), entries, Span(ch[0].start_pos, end))

    # !pose_body: "{" _NL* (entry _entry_sep+)* entry? "}"       -> (entries, where `}` ends)
    def pose_body(self, ch):
        return tuple(e for e in ch if isinstance(e, nodes.Entry)), ch[-1].end_pos

    # entry: NAME ":" NUMBER
    def entry(self, ch):
        name, _, number = ch
        return nodes.Entry(_name(name), _quantity(number), Span(name.start_pos, number.end_pos))

    # !sequence_decl: "sequence" NAME block
    def sequence_decl(self, ch):
        body, end = ch[2]
        return nodes.SequenceDecl(_name(ch[1]), body, Span(ch[0].start_pos, end))

    # !main_decl: "main" block
    def main_decl(self, ch):
        kw, (body, end) = ch
        return nodes.MainDecl(body, _tspan(kw), Span(kw.start_pos, end))

    # !block: "{" _stmt_sep* (_stmt _stmt_sep+)* _stmt? "}"      -> (statements, where `}` ends)
    def block(self, ch):
        return tuple(ch[1:-1]), ch[-1].end_pos

    # !move_stmt: "move" NAME ("in" NUMBER ease?)?
    def move_stmt(self, ch):
        duration = _quantity(ch[3]) if len(ch) > 3 else None
        ease = str(ch[4]) if len(ch) > 4 else None
        return nodes.MoveStmt(_name(ch[1]), duration, ease, _rule_span(ch))

    # !ease: "ease" (LINEAR | IN | OUT | IN_OUT)      -> the easing's token
    def ease(self, ch):
        return ch[1]

    # !hold_stmt: "hold" NUMBER
    def hold_stmt(self, ch):
        return nodes.HoldStmt(_quantity(ch[1]), _rule_span(ch))

    # !repeat_stmt: "repeat" NUMBER block
    def repeat_stmt(self, ch):
        body, end = ch[2]
        return nodes.RepeatStmt(_quantity(ch[1]), body, Span(ch[0].start_pos, end))

    # !loop_stmt: "loop" block
    def loop_stmt(self, ch):
        body, end = ch[1]
        return nodes.LoopStmt(body, Span(ch[0].start_pos, end))

    # !play_stmt: "play" NAME
    def play_stmt(self, ch):
        return nodes.PlayStmt(_name(ch[1]), _rule_span(ch))

    # !select_stmt: "select" "{" _stmt_sep* (_branch _stmt_sep+)* _branch? "}"
    def select_stmt(self, ch):
        return nodes.SelectStmt(tuple(ch[2:-1]), _rule_span(ch))

    # !on_branch: "on" event block
    def on_branch(self, ch):
        body, end = ch[2]
        return nodes.OnBranch(ch[1], body, Span(ch[0].start_pos, end))

    # !after_branch: "after" NUMBER block
    def after_branch(self, ch):
        body, end = ch[2]
        return nodes.AfterBranch(_quantity(ch[1]), body, Span(ch[0].start_pos, end))

    # !meanwhile_branch: "meanwhile" block
    def meanwhile_branch(self, ch):
        body, end = ch[1]
        return nodes.MeanwhileBranch(body, Span(ch[0].start_pos, end))

    # !until_stmt: _untilable "until" event
    def until_stmt(self, ch):
        stmt, _, event = ch
        return nodes.UntilStmt(stmt, event, Span(stmt.span.start, event.span.end))

    # !wait_stmt: "wait" event
    def wait_stmt(self, ch):
        return nodes.WaitStmt(ch[1], _rule_span(ch))

    # !send_stmt: "send" event
    def send_stmt(self, ch):
        return nodes.SendStmt(ch[1], _rule_span(ch))

    # !host_stmt: "host"
    def host_stmt(self, ch):
        return nodes.HostStmt(_rule_span(ch))

    # event: NAME | NAME NAME | NAME STRING | NAME NUMBER | STRING | NUMBER | OTHER
    def event(self, ch):
        tok = ch[0]
        if len(ch) == 2:
            return nodes.EdgeEvent(_name(ch[0]), _name(ch[1]), Span(ch[0].start_pos, ch[1].end_pos),
                                   ch[1].type != "NAME")
        if tok.type == "OTHER":
            return nodes.OtherEvent(_tspan(tok))
        if tok.type == "STRING":
            return nodes.StringLit(str(tok)[1:-1], _tspan(tok))
        if tok.type == "NUMBER":
            return _quantity(tok)
        return _name(tok)


# ---- error messages ---------------------------------------------------------

_DECL_KWS = ("SERVO", "GROUP", "POSE", "SEQUENCE", "MAIN", "FRAME", "TARGET", "INPUT", "SERIAL")
_STMT_KWS = ("MOVE", "HOLD", "REPEAT", "LOOP", "PLAY", "SELECT", "WAIT", "SEND", "HOST")
_BRANCH_KWS = ("ON", "AFTER", "MEANWHILE")
_OPTION_KWS = ("SPEED", "TRIM", "LIMIT", "REVERSE", "CHANNEL")
_EASE_KWS = ("LINEAR", "IN", "OUT", "IN_OUT")
_ENDS = ("_NL", "SEMICOLON")

_POSITION = "a position such as `90deg`, `1500us` or a raw N"
_DURATION = "a duration such as `300ms`"

# What a NUMBER is, by the token before it.
_NUMBER_AFTER = {
    "COLON": _POSITION,
    "IN": _DURATION,
    "HOLD": _DURATION,
    "FRAME": "a frame period such as `6ms`",
    "REPEAT": "a repeat count such as `3`",
    "TRIM": "a whole number such as `2` or `-2`",
    "SIGN": "a whole number such as `2` or `-2`",
    "SPEED": "a duration such as `0.25s` (as in `speed 0.25s/60deg`)",
    "SLASH": "an angle such as `60deg` (as in `speed 0.25s/60deg`)",
    "LIMIT": "a position such as `20deg` (as in `limit 20deg..160deg`)",
    "DOTDOT": "a position such as `160deg` (as in `limit 20deg..160deg`)",
    "CLOCK": "a clock frequency such as `12MHz`",
    "SERIAL": "a baud rate such as `9600`",
    "CHANNEL": "a channel number 0..31 such as `3`",
    "AFTER": _DURATION,
}
_EVENT = "an input's name (or `press NAME`, `release NAME`), a byte such as `\"w\"` or `119`, or `other`"
_BYTE = "a byte such as `\"w\"` or `119`"

# What a NAME is, by the token before it (and, for `=` and `,`, the keyword
# that opened the declaration).
_NAME_AFTER = {
    "SERVO": "a name for the servo",
    "GROUP": "a name for the group",
    "POSE": "a name for the pose",
    "SEQUENCE": "a name for the sequence",
    "TARGET": "a chip name such as `at89c52`",
    "MOVE": "the name of a pose",
    "PLAY": "the name of a sequence",
    "INPUT": "a name for the input",
}


# The settings: declarations whose word is no keyword (`setting_decl`), read by the checker.
SETTING_WORDS = ("home", "stagger", "host")
_SETTING_VALUE = {"home": "the name of a pose", "stagger": "a time such as `100ms`",
                  "host": "the host protocol `ssc32`"}
_SETTING_HELP = {"home": "`home POSE` parks the robot in POSE at power-up",
                 "stagger": "`stagger 100ms` starts the servos 100 ms apart at power-up",
                 "host": "`host ssc32` (with `serial BAUD`) lets host software drive the servos "
                         "while the program runs the statement `host`"}


def declaration_words() -> list[str]:
    """The words a declaration starts with: the keywords, then the settings `home`, `stagger` and `host`."""
    term_text = {t.name: t.pattern.value for t in _parser().terminals if isinstance(t.pattern, PatternStr)}
    return [term_text[n] for n in _DECL_KWS if n in term_text] + list(SETTING_WORDS)


def not_a_declaration(word: str) -> tuple[str, str]:
    """The message and help for a top-level item that starts with `word`, no declaration's word."""
    words = declaration_words()
    close = difflib.get_close_matches(word, words, n=1, cutoff=0.7)
    return (f"expected a declaration ({_join([f'`{w}`' for w in words])}), found `{_show(word)[1:-1]}`",
            f"did you mean `{close[0]}`?" if close else "a declaration starts with one of these words")


def _pos_of(exc: UnexpectedInput, text: str) -> int:
    if isinstance(exc, UnexpectedToken):
        pos = len(text) if exc.token.type == "$END" else exc.token.start_pos
    else:
        pos = getattr(exc, "pos_in_stream", None)
    if not isinstance(pos, int):
        pos = len(text)
    return max(0, min(pos, len(text)))


def _prefix_tokens(text: str, pos: int) -> list[Token]:
    """The tokens before `pos` (without comments and blanks), best effort."""
    toks: list[Token] = []
    try:
        for tok in _parser().lex(text[:pos]):
            if tok.value in SOFT_WORDS and tok.type != "NAME" and not _soft_here(toks, tok.value):
                tok = Token.new_borrow_pos("NAME", tok.value, tok)
            toks.append(tok)
    except Exception:
        pass
    return toks


def _soft_here(toks: list[Token], word: str) -> bool:
    """Whether a soft word after `toks` is the word, not a name. `lex` reads it without the parser,
    so this judges by what is before it: `host` where a statement starts in a block of a sequence
    or `main`, `channel` among a servo's options."""
    last = toks[-1].type if toks else ""
    if word == "host":
        opener = next((t.type for t in reversed(toks) if t.type in _DECL_KWS), "")
        return (last in ("LBRACE", "_NL", "SEMICOLON") and bool(_open_braces(toks))
                and opener in ("MAIN", "SEQUENCE"))
    opener = next((t.type for t in reversed(toks) if t.type in _DECL_KWS or t.type in _ENDS), "")
    return opener == "SERVO" and last not in ("SERVO", "EQUAL")


def _kind(tok: Token, term_text: dict[str, str]) -> str:
    """A token's type, with `..` given a readable name."""
    if term_text.get(tok.type) == "..":
        return "DOTDOT"
    return tok.type


def _show(value: str, limit: int = 24) -> str:
    value = value if len(value) <= limit else value[:limit] + "..."
    return f"`{value}`"


def _describe_char(ch: str) -> str:
    if ch == "":
        return "the end of the file"
    if ch.isprintable() and ch.isascii() and ch != "`":
        return f"`{ch}`"
    try:
        uname = unicodedata.name(ch).lower()
    except ValueError:
        uname = ""
    code = f"U+{ord(ch):04X}"
    return f"character {code}" + (f" ({uname})" if uname else "")


def _found(tok: Token, keywords: dict[str, str]) -> str:
    if tok.type == "$END":
        return "the end of the file"
    if tok.type == "_NL":
        return "the end of the line"
    if tok.value in keywords and tok.type == keywords[tok.value]:
        return f"the keyword `{tok.value}`"
    return _show(str(tok.value))


def _join(words: list[str]) -> str:
    if len(words) <= 1:
        return "".join(words)
    return ", ".join(words[:-1]) + " or " + words[-1]


def _listing(names: Iterable[str], term_text: dict[str, str]) -> str:
    return _join([f"`{term_text[n]}`" for n in names if n in term_text])


def _expected_words(expected: set[str], prev: list[str], term_text: dict[str, str]) -> list[str]:
    """The expected terminals in words, most useful first."""
    exp = set(expected)
    words: list[str] = []
    last = prev[-1] if prev else ""
    if "SIGN" in exp and "NUMBER" in exp:
        exp.discard("SIGN")
    if set(_DECL_KWS) <= exp:
        words.append("a declaration (" + _join([f"`{w}`" for w in declaration_words()]) + ")")
        exp -= set(_DECL_KWS) | {"NAME"}
    if set(_STMT_KWS) <= exp:
        words.append("a statement (" + _listing(_STMT_KWS, term_text) + ")")
        exp -= set(_STMT_KWS)
    if set(_OPTION_KWS) <= exp:
        words.append("a servo option (" + _listing(_OPTION_KWS, term_text) + ")")
        exp -= set(_OPTION_KWS)
    if set(_BRANCH_KWS) <= exp:
        words.append("a branch (`on EVENT { ... }`, `after DUR { ... }` or `meanwhile { ... }`)")
        exp -= set(_BRANCH_KWS)
    if {"NAME", "STRING", "NUMBER"} <= exp and last in ("ON", "WAIT", "SEND"):
        words.append(_BYTE if last == "SEND" else _EVENT)
        exp -= {"NAME", "STRING", "NUMBER", "OTHER"}
    if set(_EASE_KWS) <= exp:
        words.append("an easing (" + _listing(_EASE_KWS, term_text) + ")")
        exp -= set(_EASE_KWS)
    if "NUMBER" in exp:
        words.append(_NUMBER_AFTER.get(last, "a number"))
        exp.discard("NUMBER")
    if "NAME" in exp:
        words.append(_name_word(prev))
        exp.discard("NAME")
    if "PIN" in exp:
        words.append("a pin such as `P1.0`")
        exp.discard("PIN")
    ends = [e for e in _ENDS if e in exp]
    closers = [e for e in ("RBRACE", "$END") if e in exp]
    exp -= set(_ENDS) | {"RBRACE", "$END"}
    for name in sorted(exp):
        if name in term_text:
            words.append(f"`{term_text[name]}`")
    if "_NL" in ends:
        words.append("a newline")
    if "SEMICOLON" in ends:
        words.append("`;`")
    if "RBRACE" in closers:
        words.append("`}`")
    elif "$END" in closers and not words:
        words.append("the end of the file")
    return words


def _name_word(prev: list[str]) -> str:
    last = prev[-1] if prev else ""
    if last in _NAME_AFTER:
        return _NAME_AFTER[last]
    opener = next((k for k in reversed(prev) if k in _DECL_KWS), "")
    if last in ("EQUAL", "COMMA") and opener == "GROUP":
        return "a servo or group name"
    if last == "EQUAL" and opener == "POSE":
        return "the name of the pose to start from"
    if opener == "INPUT" and last == "PIN":
        return "`low` or `high`"
    if opener == "POSE" and last in ("LBRACE", "COMMA", "_NL"):
        return "a servo, group or port name"
    return "a name"


def _open_braces(toks: list[Token]) -> list[Token]:
    stack: list[Token] = []
    for tok in toks:
        if tok.type == "LBRACE":
            stack.append(tok)
        elif tok.type == "RBRACE" and stack:
            stack.pop()
    return stack


def _line_of(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def _expected_at(exc: UnexpectedInput) -> set[str]:
    """The terminals the parser could take where it stopped.

    Taken from the parse table: an error raised by the lexer carries the
    lexer's set instead, which always holds NAME and PIN (`always_accept`).
    """
    state = getattr(exc, "state", None)
    try:
        return set(state.parse_conf.parse_table.states[state.position].keys())
    except Exception:
        found = set(getattr(exc, "expected", None) or getattr(exc, "allowed", None) or ())
        return found - {"WS", "COMMENT"}


def _describe(exc: UnexpectedInput, text: str) -> tuple[str, Span, str]:
    parser = _parser()
    kws: dict[str, str] = parser.options.postlex.keywords
    term_text = {t.name: t.pattern.value for t in parser.terminals if isinstance(t.pattern, PatternStr)}
    pos = _pos_of(exc, text)
    toks = _prefix_tokens(text, pos)
    prev = [_kind(t, term_text) for t in toks]
    last_tok = toks[-1] if toks else None
    after = ""
    if last_tok is not None and last_tok.type != "_NL":
        after = f" after {_show(str(last_tok.value))}"

    if isinstance(exc, UnexpectedToken):
        tok = exc.token
        expected = _expected_at(exc)
        if tok.type == "$END":
            real = [t for t in toks if t.type != "_NL"]
            end = real[-1].end_pos if real else 0
            span = Span(end, end)
        else:
            span = Span(pos, max(pos + 1, tok.end_pos or pos + 1))
        kind = _kind(tok, term_text)
        found = _found(tok, kws)
        help_ = ""
        starts = [i + 1 for i, t in enumerate(toks) if t.type in ("_NL", "SEMICOLON")]
        stray = toks[starts[-1] if starts else 0] if toks and (not starts or starts[-1] < len(toks)) else None
        if (stray is not None and stray.type == "NAME" and stray.value not in SETTING_WORDS
                and not _open_braces(toks)):
            message, help_ = not_a_declaration(stray.value)
            return message, Span(stray.start_pos, stray.end_pos), help_
        if (last_tok is not None and last_tok.type == "NAME" and last_tok.value in SETTING_WORDS
                and {"NAME", "NUMBER"} <= expected and not _open_braces(toks)):
            word = last_tok.value
            return (f"expected {_SETTING_VALUE[word]} after `{word}`, found {found}", span,
                    _SETTING_HELP[word])
        if last_tok is not None and last_tok.type == "HOST" and tok.type != "$END":
            help_ = ("in a block, `host` stands alone; `host ssc32` is a declaration, written at the top "
                     "level" if tok.value.lower() == "ssc32" else
                     "put each statement on its own line, or separate them with `;`" if kind == "NAME" else "")
            words = _expected_words(expected, prev, term_text)
            return f"expected {_join(words)} after `host`, found {found}", span, help_
        if tok.type in kws.values() and "NAME" in expected:
            return (f"`{tok.value}` is a keyword and cannot be used as a name, expected {_name_word(prev)}",
                    span, f"keywords are reserved; choose another name, such as `{tok.value}_1`")
        if kind == "SIGN" and "NUMBER" in expected and tok.value == "-":
            return ("a negative number is allowed only after `trim`", span,
                    "positions, durations and counts are never negative")
        if kind == "NUMBER" and "IN" in expected and prev and prev[-1] == "NAME":
            return (f"expected `in` before the duration, found {found}", span,
                    f"write `move {toks[-1].value} in {tok.value}`")
        if kind == "STRING" and "STRING" not in expected:
            return ("unexpected string: .servo has no strings except a byte after `on`, `wait` or `send`", span,
                    "names and chip names are written without quotes")
        if kind == "RBRACE" and "RBRACE" not in expected and not _open_braces(toks):
            return ("unexpected `}`: there is no open block to close", span, "")
        if tok.type == "$END":
            open_ = _open_braces(toks)
            if "RBRACE" in expected and open_:
                line = _line_of(text, open_[-1].start_pos)
                return (f"the file ends before the `}}` that closes the block opened at line {line}",
                        span, "add the missing `}`")
            words = _expected_words(expected, prev, term_text)
            return (f"the file ends too early: expected {_join(words)}{after}", span, "")
        words = _expected_words(expected, prev, term_text)
        complete = bool(set(_ENDS) & expected)
        if complete and not (expected - set(_ENDS) - {"RBRACE", "$END"}):
            message = f"expected a newline or `;` after the statement, found {found}"
            if tok.type in kws.values() and prev and prev[-1] == "NAME":
                help_ = "put each statement on its own line, or separate them with `;`"
        else:
            message = f"expected {_join(words)}{after}, found {found}"
        if kind == "PIN" and "NAME" in expected:
            help_ = "a pin is only written in a `servo` or `input` declaration; here use the name"
        elif kind == "NAME" and "PIN" in expected:
            help_ = "pins are written as a port and a bit: `P0.0` to `P2.7`"
        elif kind == "NAME" and expected & set(_EASE_KWS):
            help_ = "the easings are `linear`, `in`, `out` and `in-out`"
        elif kind == "NUMBER" and "NAME" in expected:
            help_ = "names start with a letter or `_`"
        elif tok.value == "ease" and "IN" in expected:
            help_ = "an easing needs a duration first: `move POSE in 500ms ease in-out`"
        return message, span, help_

    # UnexpectedCharacters: a character no token can start with.
    ch = text[pos:pos + 1]
    span = Span(pos, pos + 1) if ch else Span(pos, pos)
    expected = _expected_at(exc)
    shown = _describe_char(ch)
    if ch == '"':
        return ("this string has no closing `\"` on its line", span,
                "a byte is written as one character between quotes, `\"w\"`, or as a number 0..255")
    if ch == "'":
        return (f"unexpected quote {shown}", span,
                "a byte is written between double quotes, `\"w\"`; names and chip names without quotes")
    if ch == ".":
        return ("unexpected `.`", span,
                "a number needs digits on both sides of its point, as in `0.25s`; "
                "a pin is written `P1.0`; a limit range is written `20deg..160deg`")
    words = _expected_words(expected, prev, term_text) if expected else []
    message = f"unexpected {shown}" if not shown.startswith("`") else f"unexpected character {shown}"
    if words:
        message += f": expected {_join(words)}{after}"
    return message, span, ""
