"""What the docs ask a reader to run, read out of the Markdown: code blocks, command lines and
their ``doc-test`` markers.

* **Blocks**: fenced blocks (```` ```python ````, ```` ```bash ````, ```` ```toml ````, or
  without a language) and indented blocks (four spaces more than the text around them, after a
  blank line), inside list items too.
* **Commands**: the lines of a shell block (fenced ``bash``/``sh``/``console``, or an indented or
  unlabelled block whose lines start with a command word such as ``hertzmap`` or
  ``.venv/bin/python``), with ``$ `` prompts removed and ``\\`` continuations joined; and inline
  code spans in the prose or a table whose text starts with a command word
  (`` `hertzmap plot --paper fig02` ``).
* **Markers**: an HTML comment ``<!-- doc-test: WORD ... -->`` (invisible when rendered). On a
  line of its own it applies to the next block; inside a line of prose or a table row it applies
  to the inline commands of that line. The words are in :data:`MARKER_WORDS`.
"""
from __future__ import annotations

import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path

#: marker words: what the test does instead of (or besides) running the block
MARKER_WORDS = {
    "cluster": "needs a cluster, a batch system or other hosts: parsed (argparse, --dry-run)",
    "long": "takes minutes: parsed (argparse and --dry-run; a script compiled), not run",
    "server": "starts a server that runs until stopped: parsed (argparse), not run",
    "usage": "a synopsis: every option it names exists, and it names every option",
    "output": "sample output of the command on its '$ ' line: compared line by line, in order "
              "('...' matches anything); 'output shape': numbers and hashes free (a timed run)",
    "prints": "numbers the output must contain: 'prints 0.1799@1e-6 36' (value@tolerance; "
              "without @, to the last digit written); each also written in the text nearby",
    "python": "a Python snippet written as an indented block: run like a ```python block",
    "fresh": "run this Python block in a namespace of its own (not the page's)",
    "file": "the reader saves this block as 'file PATH': the test writes it there first",
    "edits": "rewrites a file of the repository: parsed, not run",
    "run": "run a benchmarks/ script (they are parsed only by default: they measure, for minutes)",
}

#: first words of a line that make it a command
COMMAND_WORDS = ("hertzmap", ".venv/bin/hertzmap", "python", "python3", ".venv/bin/python",
                 "bash", "pip", "export", "dask", "ssh", "pytest", "git", "squeue", "sinfo",
                 "sacctmgr", "scontrol", "scancel", "kill")
_ENV_ASSIGN = re.compile(r"^[A-Z_][A-Z0-9_]*=\S*$")

_MARKER = re.compile(r"<!--\s*doc-test:\s*(.*?)\s*-->")
_FENCE = re.compile(r"^(\s*)(`{3,}|~{3,})\s*([\w+-]*)\s*$")
_LIST_ITEM = re.compile(r"^(\s*)([-*+]|\d+[.)])\s+")
_INLINE = re.compile(r"(?<!`)`([^`\n]+)`(?!`)")


@dataclass
class Marker:
    word: str
    args: list[str]
    line: int


class _Marked:
    """What blocks and commands share: their markers' words, and where they are."""
    path: Path
    line: int
    markers: list[Marker]

    @property
    def words(self) -> set[str]:
        return {m.word for m in self.markers}

    def marker(self, word: str) -> Marker | None:
        return next((m for m in self.markers if m.word == word), None)

    def where(self) -> str:
        return f"{self.path.name}:{self.line}"


@dataclass
class Block(_Marked):
    """A code block: ``lang`` is the fence's info string ('' for none; 'indented' for an
    indented block); ``line`` the 1-based line of its first content line."""
    path: Path
    line: int
    lang: str
    text: str
    markers: list[Marker] = field(default_factory=list)

    @property
    def kind(self) -> str:
        """python, shell, console (commands with their output), toml, or text."""
        if self.lang == "python" or (self.lang == "indented" and "python" in self.words):
            return "python"
        if self.lang == "toml":
            return "toml"
        lines = [ln for ln in self.text.splitlines() if ln.strip()]
        if self.lang in ("", "text", "console", "indented") and lines \
                and lines[0].lstrip().startswith("$ "):
            return "console"
        if self.lang in ("bash", "sh", "shell", "console"):
            return "shell"
        if self.lang in ("", "indented") and any(is_command(ln) for ln in lines):
            return "shell"
        return "text"


@dataclass
class Command(_Marked):
    """One command line as a reader would type it; ``inline`` for a code span in the text.
    ``context`` is the text line (or table row) it came from, for numbers nearby."""
    path: Path
    line: int
    text: str
    markers: list[Marker] = field(default_factory=list)
    inline: bool = False
    context: str = ""
    output: list[str] = field(default_factory=list)


def parse_marker(text: str, line: int) -> list[Marker]:
    """The markers of one ``doc-test:`` comment; a word not in MARKER_WORDS is an error (a typo
    would otherwise turn its check off without a word)."""
    out = []
    for part in text.split(";"):
        words = part.split()
        if words:
            if words[0] not in MARKER_WORDS:
                raise ValueError(f"line {line}: doc-test marker {words[0]!r} is not one of "
                                 f"{sorted(MARKER_WORDS)}")
            out.append(Marker(words[0], words[1:], line))
    return out


def is_command(line: str) -> bool:
    s = line.strip()
    if s.startswith("$ "):
        s = s[2:]
    try:
        words = shlex.split(s, comments=True)
    except ValueError:
        words = s.split()
    while words and _ENV_ASSIGN.match(words[0]):
        words = words[1:]
        if words and words[0] in COMMAND_WORDS:
            return True
    return bool(words) and words[0] in COMMAND_WORDS and (len(words) > 1 or words[0] == "bash")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip(" "))


def blocks(path: Path, text: str | None = None) -> list[Block]:
    """Every code block of a Markdown file, with the markers on the lines just before it."""
    lines = (path.read_text() if text is None else text).splitlines()
    out: list[Block] = []
    pending: list[Marker] = []
    base = 0              # indentation of the text the next indented block is relative to
    prev_blank = True
    i = 0
    while i < len(lines):
        ln = lines[i]
        m = _FENCE.match(ln)
        if m:
            ind, fence, lang = len(m.group(1)), m.group(2), m.group(3)
            j = i + 1
            body = []
            while j < len(lines) and not (lines[j].strip().startswith(fence)
                                          and lines[j].strip().strip(fence[0]) == ""):
                body.append(lines[j][ind:] if lines[j][:ind].strip() == "" else lines[j].lstrip())
                j += 1
            out.append(Block(path, i + 2, lang or "", "\n".join(body) + "\n", pending))
            pending = []
            i = j + 1
            prev_blank = False
            continue
        stripped = ln.strip()
        mk = _MARKER.fullmatch(stripped)
        if mk:
            pending += parse_marker(mk.group(1), i + 1)
            i += 1
            continue
        if not stripped:
            prev_blank = True
            i += 1
            continue
        if prev_blank and _indent(ln) >= base + 4:
            j = i
            body = []
            while j < len(lines) and (not lines[j].strip() or _indent(lines[j]) >= base + 4):
                body.append(lines[j][base + 4:])
                j += 1
            while body and not body[-1].strip():
                body.pop()
            out.append(Block(path, i + 1, "indented", "\n".join(body) + "\n", pending))
            pending = []
            i = j
            prev_blank = True
            continue
        li = _LIST_ITEM.match(ln)
        if li:
            base = len(li.group(0))
        elif _indent(ln) < base:
            base = _indent(ln)
        pending = []            # a marker applies to the block right after it only
        prev_blank = False
        i += 1
    return out


def inline_commands(path: Path, text: str | None = None) -> list[Command]:
    """Code spans in the prose and tables (outside blocks) whose text is a command."""
    lines = (path.read_text() if text is None else text).splitlines()
    inside = set()
    for b in blocks(path, "\n".join(lines)):
        n = b.text.count("\n")
        if b.lang == "indented":
            inside.update(range(b.line, b.line + n))
        else:                                   # the fences too
            inside.update(range(b.line - 1, b.line + n + 1))
    out = []
    for k, ln in enumerate(lines, 1):
        if k in inside:
            continue
        found = [(mk.start(), m) for mk in _MARKER.finditer(ln)
                 for m in parse_marker(mk.group(1), k)]
        spans = [(sp.start(), sp.group(1)) for sp in _INLINE.finditer(ln)
                 if is_command(sp.group(1))]
        for i, (at, span) in enumerate(spans):
            # a `prints` or `output` marker is about the command span just before it
            after = spans[i + 1][0] if i + 1 < len(spans) else len(ln)
            markers = [m for pos, m in found
                       if m.word not in _OUTPUT_WORDS or at < pos < after]
            parts = split_and(span)
            for j, part in enumerate(parts):
                out.append(Command(path, k, part, _markers_of_part(markers, j, len(parts)),
                                   inline=True, context=ln))
    return out


#: markers about what a command prints: in ``a && b`` they are b's (a makes what b reads)
_OUTPUT_WORDS = {"prints", "output"}


def _markers_of_part(markers: list[Marker], j: int, n: int) -> list[Marker]:
    return [m for m in markers if j == n - 1 or m.word not in _OUTPUT_WORDS]


def split_and(text: str) -> list[str]:
    """``a && b`` -> [a, b] (outside quotes)."""
    parts, cur, quote = [], "", None
    i = 0
    while i < len(text):
        c = text[i]
        if quote:
            cur += c
            if c == quote:
                quote = None
        elif c in "'\"":
            quote = c
            cur += c
        elif text.startswith("&&", i):
            parts.append(cur.strip())
            cur = ""
            i += 2
            continue
        else:
            cur += c
        i += 1
    parts.append(cur.strip())
    return [p for p in parts if p]


def block_commands(block: Block) -> list[Command]:
    """The commands of a shell or console block: prompts removed, continuations joined,
    ``&&`` split; a console block's other lines are the output of the command before them."""
    out: list[Command] = []
    lines = block.text.splitlines()
    i = 0
    console = block.kind == "console"
    while i < len(lines):
        ln = lines[i]
        s = ln.strip()
        n = i
        if console and not s.startswith("$ "):
            if out:
                out[-1].output.append(ln)
            i += 1
            continue
        if s.startswith("$ "):
            s = s[2:]
        while s.endswith("\\") and i + 1 < len(lines):
            i += 1
            s = s[:-1].rstrip() + " " + lines[i].strip()
        i += 1
        if not s or s.startswith("#"):
            continue
        if not is_command(s):
            continue
        parts = split_and(s)
        for j, p in enumerate(parts):
            out.append(Command(block.path, block.line + n, p,
                               _markers_of_part(block.markers, j, len(parts)), context=s))
    return out


def all_commands(path: Path) -> list[Command]:
    cmds = []
    for b in blocks(path):
        if b.kind in ("shell", "console"):
            cmds += block_commands(b)
    return cmds + inline_commands(path)
