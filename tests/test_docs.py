"""The README and the documentation: every snippet they show is executed, so none can drift from the code; every
page stays short; and nothing in the repository speaks of how it was made.

* every ```python block of README.md and docs/*.md runs as it is (in a temporary working folder);
* every ```toml block loads with the loader of its kind (motor description, column mapping, experiment settings);
* every ``pgcomm ...`` line of a shell block parses with the real argument parser (not run: the README's rig
  block runs in tests/test_readme_rig.py, the others take minutes), and every inline ```pgcomm COMMAND --option```
  names a command and options that exist (inline spans leave out required arguments, so they cannot be parsed whole);
* the example scripts of ``examples/`` compile here; the documentation build runs them (sphinx-gallery, ``.ci/run``);
* every documentation page is at most :data:`MAX_PAGE_LINES` lines;
* no tracked file of the README, ``src/``, ``docs/``, ``tests/``, ``bench/`` or ``examples/`` names a numbered ticket
  or milestone, the sitting it was written in, or before/after wording (:data:`PROCESS_WORDS`); measured figures
  live on docs/validation.md with their commands.
"""

from __future__ import annotations

import argparse
import re
import shlex
import subprocess
from pathlib import Path

import pytest

from pgcomm.cli import COMMANDS, build_parser

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
EXAMPLES = sorted((ROOT / "examples").glob("*.py"))

_FENCE = re.compile(r"^```([\w-]*)[^\n]*\n(.*?)^```", re.S | re.M)
_INLINE = re.compile(r"(?<!`)`((?:python -m )?pgcomm [^`\n]+)`(?!`)")
_SHELL = ("sh", "bash", "shell", "console", "")


def _blocks(language: str | tuple[str, ...]):
    """``(id, code)`` of every fenced block in that language on every page, ids as ``page:n``."""
    langs = (language,) if isinstance(language, str) else language
    out = []
    for page in PAGES:
        for n, m in enumerate(_FENCE.finditer(page.read_text()), start=1):
            if m.group(1) in langs:
                out.append(pytest.param(m.group(2), id=f"{page.relative_to(ROOT)}:{n}"))
    return out


def _without_fences(text: str) -> str:
    return _FENCE.sub("", text)


def _command_lines():
    """Every ``pgcomm`` invocation in the shell blocks, split at ``&&``, ``;`` and ``|``, comments dropped; a line
    ending in a backslash continues on the next, as in the shell."""
    out = []
    for param in _blocks(_SHELL):
        code, = param.values
        for line in re.sub(r"\\\n[ \t]*", " ", code).splitlines():
            for part in re.split(r"&&|;|\|", line.split(" #", 1)[0]):
                argv = shlex.split(part, comments=True)
                if argv[:3] == ["python", "-m", "pgcomm"]:
                    argv = argv[2:]
                if argv[:1] == ["pgcomm"]:
                    out.append(pytest.param(argv[1:], id=f"{param.id}:{' '.join(argv[1:3])}"))
    return out


def _inline_commands():
    out = []
    for page in PAGES:
        for m in _INLINE.finditer(_without_fences(page.read_text())):
            span = m.group(1).removeprefix("python -m ")
            out.append(pytest.param(span, id=f"{page.relative_to(ROOT)}:{span[:40]}"))
    return out


def _option_strings(command: str) -> set[str]:
    p = argparse.ArgumentParser(prog=f"pgcomm {command}")
    COMMANDS[command].configure(p)
    return {s for action in p._actions for s in action.option_strings}


@pytest.mark.parametrize("code", _blocks("python"))
def test_python_snippet_runs(code, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<snippet>", "exec"), {"__name__": "__snippet__"})


@pytest.mark.parametrize("code", _blocks("toml"))
def test_toml_snippet_loads(code, tmp_path):
    from pgcomm import load_experiment, load_motor
    from pgcomm.io.logs import load_column_mapping

    path = tmp_path / "snippet.toml"
    path.write_text(code)
    if re.search(r'^kind\s*=\s*"rotary"', code, re.M):
        from pgcomm.io.config import load_rotary_motor

        assert load_rotary_motor(path).pole_pairs >= 1
    elif re.search(r"^pole_pitch\s*=", code, re.M):
        motor = load_motor(path)
        assert motor.n_coil_sets >= 1
    elif re.search(r"^\[columns\]", code, re.M):
        assert load_column_mapping(path) is not None
    else:
        assert load_experiment(path) is not None


@pytest.mark.parametrize("argv", _command_lines())
def test_command_line_parses(argv, capsys):
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # the parser's one-line error is on stderr
        pytest.fail(f"pgcomm {shlex.join(argv)}: exit {e.code}: {capsys.readouterr().err.strip()}")
    assert args.command == argv[0]


@pytest.mark.parametrize("span", _inline_commands())
def test_inline_command_names_real_options(span):
    tokens = span.split()
    command = tokens[1]
    if command.startswith("-"):  # pgcomm --help, pgcomm --version
        assert command in {"--help", "-h", "--version"}, span
        return
    if command.isupper():  # a placeholder: pgcomm COMMAND --help
        return
    assert command in COMMANDS, f"{span!r}: no command {command!r} (commands: {', '.join(COMMANDS)})"
    known = _option_strings(command)
    unknown = [o for o in re.findall(r"(?<![\w-])--[a-z][a-z0-9-]*", span) if o not in known]
    assert not unknown, f"{span!r}: pgcomm {command} has no option {', '.join(unknown)}"


def test_pages_have_snippets_and_every_example_compiles():
    # guards the extraction itself: a changed fence syntax would otherwise make every test above vanish
    assert len(_blocks("python")) >= 5 and len(_command_lines()) >= 20 and len(_inline_commands()) >= 20
    assert len(EXAMPLES) >= 3
    for path in EXAMPLES:
        code = path.read_text()
        compile(code, str(path), "exec")
        assert code.lstrip().startswith('"""'), f"{path.name}: sphinx-gallery needs a docstring with a title first"


#: A documentation page answers one question; longer pages are split.
MAX_PAGE_LINES = 200

#: Wording about how the code was made rather than what it does: a numbered ticket or milestone (with or without a
#: hyphen or "#"; a milestone's number is not followed by a unit, so "stops 3 s later" is not one), the sitting it
#: was written in, a rerun told as history, an earlier figure in parentheses and a change told against what was
#: there. The words are split in the source so that this file does not match itself.
PROCESS_WORDS = re.compile(
    r"\biss" r"ues?[ -]?#?\d"
    r"|\bst" r"ops?[ -]?#?\d+(?![\d.,]|\s*(?:s|ms|µs|us|min|h|%|x|Hz|kHz|rad|deg|samples?|cycles?|times)\b)"
    r"|\bsess" r"ions?\b"
    r"|\brer" r"an\b"
    r"|\(bef" r"ore:"
    r"|\bbef" r"ore (?:this|the) ch" r"ange\b",
    re.IGNORECASE)
#: pytest's fixture scope is a name of the tool, not a process word.
_ALLOWED = re.compile(r"scope=[\"']sess" r"ion[\"']")
_SCANNED = ("README.md", "src", "docs", "tests", "bench", "examples")
_TEXT_SUFFIXES = {".py", ".md", ".rst", ".toml", ".txt", ".cfg", ".c", ".h", ".ini", ".yaml", ".yml"}


def _tracked_files() -> list[Path]:
    """The repository's tracked files under :data:`_SCANNED` (``git ls-files``), else every text file there."""
    try:
        out = subprocess.run(["git", "ls-files", "-z", "--", *_SCANNED], cwd=ROOT, capture_output=True, check=True,
                             timeout=60).stdout.decode()
        files = [ROOT / p for p in out.split("\0") if p]
    except (OSError, subprocess.SubprocessError):
        files = []
    if not files:  # not a git checkout (an unpacked sdist): walk the folders, leaving out what builds generate
        skip = {"__pycache__", "_build", "auto_examples", "generated", ".pytest_cache"}
        files = [p for top in _SCANNED for p in ([ROOT / top] if (ROOT / top).is_file() else (ROOT / top).rglob("*"))
                 if p.is_file() and not skip.intersection(p.relative_to(ROOT).parts)]
    return [p for p in files if p.suffix in _TEXT_SUFFIXES and p.is_file()]


def test_no_process_words_in_the_repository():
    files = _tracked_files()
    assert any(p.name == "test_docs.py" for p in files) and len(files) >= 50, "the scan found too few files"
    hits = []
    for path in files:
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(text.splitlines(), start=1):
            m = PROCESS_WORDS.search(_ALLOWED.sub("", line))
            if m:
                hits.append(f"{path.relative_to(ROOT)}:{n}: {m.group(0)!r} in {line.strip()[:100]!r}")
    assert not hits, "process words (say what the code does, not how it was made):\n" + "\n".join(hits)


def test_process_words_pattern_catches_what_it_should_and_nothing_else():
    caught = ["see iss" "ue 18", "Iss" "ue 10's target", "the iss" "ue-8 bars", "the twin of st" "op 36",
              "St" "op 40 r" "eran the others", "st" "op 34's note", "logged in one sess" "ion", "2.5 % (bef" "ore: 3.0 %)",
              "bef" "ore this ch" "ange", "iss" "ues 3 and 4"]
    left = ["the stop reason", "a drive's 'stop' command", "stop_when_resolved", "issued at 1 kHz",
            "a rerun skips finished motors", "before the first computation", "stops 3 s later", "stop 2.5 ms after"]
    assert [t for t in caught if not PROCESS_WORDS.search(t)] == []
    assert [t for t in left if PROCESS_WORDS.search(t)] == []
    assert _ALLOWED.sub("", '@pytest.fixture(scope="sess' 'ion")') == "@pytest.fixture()"


@pytest.mark.parametrize("page", sorted((ROOT / "docs").glob("*.md")), ids=lambda p: p.name)
def test_every_page_is_short(page):
    lines = len(page.read_text(encoding="utf-8").splitlines())
    assert lines <= MAX_PAGE_LINES, f"docs/{page.name}: {lines} lines, at most {MAX_PAGE_LINES}: split the page"
