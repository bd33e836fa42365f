"""The documentation's examples are tests of their output, not only of running.

Every fenced ```sh and ```python block of README.md and of **every** page under docs/
(the user guide and the "how it works" pages alike) is an example: each of its command
lines runs here as written, from the repository root, through bash (pipes and `>`
redirections as typed), with `fbgforge` the command line CI built and `python` the
interpreter of these tests; a ```python block runs on its own (test_docs.py), one that
imports `mcap` with $FBGFORGE_PYTHON (the venv of the ROS 2 world's readers .ci/run
makes). A fenced block with no language that holds a command line fails
(`test_no_command_hides_in_an_untyped_block`): examples are marked ```sh so that they
run; terminal captures and diagrams are ```text.

* `cargo run --release -p fbgforge-studies -- STUDY …` runs the studies binary that
  `cargo test --release` built (target/release/fbgforge-studies: `cargo run` with other
  packages selected could unify features differently and compile again); a line whose
  comment says `CI: --quick` runs in the study's `--quick` form (its smoke run, whose
  numbers studies/tests check), every other study line runs as written.
* `fbgforge synth-stream … --port 0` starts in the background (a simulated Hyperion),
  as a reader starts it in a terminal of its own; the port it prints replaces `PORT`
  in the block's later lines. Each line that reads `PORT` is a client of a stream of
  its own: the docs' client lines are alternatives (a stream stops after its
  `--duration-s`, so a second client would find nothing), so every client line after
  the first gets the stream started again, as written. What a stream prints is part of
  the example's output: its first lines (`listening on …`) where it starts, the rest
  (`served … frames`) after its client's output, once it has stopped (at most 5 s
  after the client; a stream still running then is stopped).

When an example block is followed directly (only blank lines between) by a ```text
block, that block is the example's printed answer and is asserted:

* each of its lines must appear, in order, among the lines the example printed (the
  example may print more lines than the docs show: abridged output is allowed);
* `…` stands for any text; runs of spaces match any run of spaces (tables align);
* every number of the expected line must be printed within **1 % or one unit of its
  last shown digit, whichever is larger** (`11.998` matches 11.99–12.01 and
  11.88–12.12 by the 1 %; `Q 249.36` matches 246.9–251.9; an integer `67` matches
  66–68): the docs round, the machines differ in the last bits, a model change that
  moves an answer fails. Digits with two dots or more (`127.0.0.1`) are text.

A block that runs but prints nothing worth asserting (it writes files a later block
shows, or its numbers are timings of the machine) is listed in UNASSERTED with the
reason; any other block without a printed answer fails
(`test_every_example_that_prints_results_asserts_them`). Commands that cannot run on a
fresh clone (the reader's own files, the install commands CI itself runs) are
listed in SKIPPED with the reason, and the test fails on a command that is neither run
nor listed, so a new example cannot go unchecked by accident. The census (blocks
total / run / asserted / not run): `python python/tests/test_doc_outputs.py`.

Why this and not trycmd/snapbox: the examples are half Python, and pytest already
runs them with the installed package and the command line CI built (test_docs.py);
trycmd would check the shell half only, in a second harness, and compares numbers as
text (a `[..]` wildcard in place of a number asserts nothing about it), where the
docs' claims are numbers with a tolerance.
"""

import math
import os
import shutil
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

from conftest import ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]

# Command lines not run, with the reason (the test below fails on any other).
SKIPPED = {
    "cargo install": "the install itself: .ci/run runs `cargo install --path . --locked` before the tests",
    "cargo test": "the test command itself (.ci/run)",
    "cargo bench": "not run: a criterion benchmark, whose numbers are the machine's (CI compiles it: clippy --all-targets)",
    "python3 -m venv": "the package's install: .ci/run makes the venv and installs it as written",
    "pip install": "the package's install (.ci/run)",
    "python -m pytest": "this very test suite",
    "Peaks.2025": "the reader's own interrogator log, growing (docs/guide/live.md; fixtures/ hold real ones, tested in tests/verify and tests/array/live*.rs)",
    "studies/peers/": "not run: needs the peers' sources (PEERS_SRC, outside this repository), SciPy and scikit-learn; the study half runs on the line before it",
}

# Blocks that run but whose output is not asserted, by page:line of the block, with
# the reason. Every other block that runs carries its printed answer.
UNASSERTED = {}

# Commands too slow for CI, with the test that asserts their output instead (none:
# the slowest, `optimize` of the 16 mm module and the README's 81-step Case I sweep,
# take 7 s of CPU each).
SLOW = {}

STUDY = "cargo run --release -p fbgforge-studies --"
# `cargo run --release` alone is the binary with no arguments (the default build).
DEFAULT_BUILD = "cargo run --release"


def blocks(path):
    """The fenced blocks of a page, in order: (line, language, code, start, end)."""
    text = path.read_text()
    out = []
    for m in re.finditer(r"^```([\w-]*)[^\n]*\n(.*?)^```[ \t]*$", text, re.S | re.M):
        out.append((text[: m.start()].count("\n") + 1, m.group(1), m.group(2), m.start(), m.end()))
    return out, text


def command_lines(code):
    """The command lines of a shell block: continuations joined, comments dropped;
    each with its comment (what it says of how CI runs it)."""
    out = []
    for cmd in re.sub(r"\\\n\s*", " ", code).splitlines():
        cmd, _, comment = cmd.partition("  #")
        cmd = cmd.strip()
        if cmd and not cmd.startswith("#"):
            out.append((cmd, comment))
    return out


def examples():
    """Every example block with its expected output (or None): (page, line, lang,
    commands or code, expected lines)."""
    out = []
    for page in PAGES:
        bl, text = blocks(page)
        for i, (line, lang, code, _, end) in enumerate(bl):
            if lang not in ("sh", "python"):
                continue
            expected = None
            if i + 1 < len(bl):
                nline, nlang, ncode, nstart, _ = bl[i + 1]
                if nlang == "text" and text[end:nstart].strip() == "":
                    expected = [l for l in ncode.splitlines() if l.strip()]
            if lang == "sh":
                out.append((page, line, lang, command_lines(code), expected))
            else:
                out.append((page, line, lang, code, expected))
    return out


EXAMPLES = examples()


# The programs an example line may call: fbgforge, Python, a study, and `head`/`cat`/
# `mkdir` to show a file a command wrote or make a folder.
RUNNABLE = ("fbgforge", "python", "head", "cat", "mkdir")


def skip_reason(cmd):
    for key, why in SKIPPED.items():
        if key in cmd:
            return why
    return None


def runs(cmd):
    """Whether a command line runs here (else it is skipped with a reason)."""
    return not skip_reason(cmd) and (cmd.split()[0] in RUNNABLE or cmd.startswith(STUDY) or cmd == DEFAULT_BUILD)


def where(page, line):
    return f"{page.relative_to(ROOT).as_posix()}:{line}"


def census():
    """Example blocks total / run / asserted / not run (every line skipped), and the
    skipped lines marked `not run:` (ROS 2, a benchmark)."""
    total = len(EXAMPLES)
    ran = [e for e in EXAMPLES if e[2] == "python" or any(runs(c) for c, _ in e[3])]
    asserted = [e for e in ran if e[4]]
    marked = [c for e in EXAMPLES if e[2] == "sh" for c, _ in e[3] if (skip_reason(c) or "").startswith("not run:")]
    return {"blocks": total, "run": len(ran), "asserted": len(asserted),
            "not_run": total - len(ran), "lines_marked_not_run": len(marked)}


def number_close(expected, actual):
    """`actual` within 1 % of `expected` or one unit of its last shown digit."""
    e, a = float(expected), float(actual)
    decimals = len(expected.split(".")[1].split("e")[0].split("E")[0]) if "." in expected else 0
    return abs(a - e) <= max(0.01 * abs(e), 10.0 ** -decimals) + 1e-12


NUMBER = r"[-+−]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"
# Digits with two dots or more (an address, `127.0.0.1`) are text, not numbers.
DOTTED = r"\d+(?:\.\d+){2,}"


def tokens(expected):
    """One expected line as tokens: ("num", text), ("any",), ("ws",), ("lit", text)."""
    # Spaces beside a `…` belong to it (`FAIL …` matches a line ending in FAIL).
    expected = re.sub(r"\s*…\s*", "…", expected.strip())
    out = []
    for tok in re.split(rf"(…|{DOTTED}|{NUMBER}|\s+)", expected):
        if not tok:
            continue
        if tok == "…":
            out.append(("any",))
        elif re.fullmatch(DOTTED, tok):
            out.append(("lit", tok))
        elif tok.isspace():
            out.append(("ws",))
        elif re.fullmatch(NUMBER, tok):
            out.append(("num", tok.replace("−", "-")))
        else:
            out.append(("lit", tok))
    return out


NUMBER_AT = re.compile(NUMBER)


def match_from(toks, s, i):
    """Whether `toks` match `s` from column `i` (a `…` tries every length)."""
    if not toks:
        return True
    t, rest = toks[0], toks[1:]
    if t[0] == "lit":
        return s.startswith(t[1], i) and match_from(rest, s, i + len(t[1]))
    if t[0] == "ws":
        m = re.compile(r"\s+").match(s, i)
        return bool(m) and match_from(rest, s, m.end())
    if t[0] == "num":
        m = NUMBER_AT.match(s, i)
        inside = i > 0 and (s[i - 1].isdigit() or (s[i - 1] == "." and i > 1 and s[i - 2].isdigit()))
        if not m or inside:  # not the tail of a longer number
            return False
        return number_close(t[1], m.group(0).replace("−", "-")) and match_from(rest, s, m.end())
    return any(match_from(rest, s, j) for j in range(i, len(s) + 1))


def matches(expected, actual):
    """Whether `actual` holds the expected line, from any column."""
    toks = tokens(expected)
    return any(match_from(toks, actual, start) for start in range(len(actual) + 1))


def assert_printed(expected_lines, output, where):
    """Every expected line is printed, in order (a subsequence of the output's lines)."""
    lines = output.splitlines()
    at = 0
    for exp in expected_lines:
        if exp.strip() == "…":  # "more lines here": the lines are a subsequence already
            continue
        while at < len(lines) and not matches(exp, lines[at]):
            at += 1
        assert at < len(lines), (
            f"{where}: the docs say the example prints\n  {exp}\n"
            f"(numbers within 1 % or one unit of the last digit), after the lines before it; it printed:\n{output}"
        )
        at += 1


def test_the_matcher_compares_numbers_with_its_tolerance():
    assert matches("K = 11.998 pm/N", "fit: K = 12.004 pm/N (R² 0.999)")
    assert not matches("K = 11.998 pm/N", "K = 12.2 pm/N")
    assert matches("A 0 B 100 …", "A 0.4 B 100.3 C 0 D 0")
    assert not matches("B 100", "B 44.9")
    assert matches("verdict: PASS", "verdict:   PASS")
    assert not matches("verdict: PASS", "verdict: FAIL")
    assert matches("built 5 designs, 67 files", "built 5 designs, 67 files in 1.02 s")
    assert not matches("built 5 designs, 54 files", "built 5 designs, 67 files in 1.02 s")
    assert matches("listening on 127.0.0.1:…", "listening on 127.0.0.1:45429")
    assert not matches("listening on 127.0.0.1:…", "listening on 127.0.0.2:45429")
    with pytest.raises(AssertionError):
        assert_printed(["b 2", "a 1"], "a 1\nb 2", "order")


def test_every_example_is_run_or_its_skip_stated():
    """No command of the docs goes unchecked without a stated reason."""
    for page, line, lang, body, _ in EXAMPLES:
        if lang != "sh":
            continue
        for cmd, _ in body:
            assert runs(cmd) or skip_reason(cmd), f"{where(page, line)}: `{cmd}` is neither run nor skipped with a reason"


# A line of an untyped block that reads as a command: a program, a subcommand word,
# then an argument (a terminal capture's title, `fbgforge live · …`, is not one).
COMMAND = re.compile(r"^(fbgforge|cargo|python3?|ros2|pip)\s+[a-z][\w-]*(\s+[-\w./\"']|\s*$)", re.M)


def test_no_command_hides_in_an_untyped_block():
    """A command in a fence without a language would go unrun: examples are ```sh."""
    hidden = []
    for page in PAGES:
        for line, lang, code, _, _ in blocks(page)[0]:
            if lang == "" and COMMAND.search(code):
                hidden.append(f"{where(page, line)}: {COMMAND.search(code).group(0)}")
    assert not hidden, "\n".join(hidden)


def test_every_example_that_prints_results_asserts_them():
    """A block that runs shows its printed answer (a ```text block after it), or says
    in UNASSERTED why it has none."""
    bare = [where(p, l) for p, l, lang, body, exp in EXAMPLES
            if not exp and (lang == "python" or any(runs(c) for c, _ in body))
            and where(p, l) not in UNASSERTED]
    assert not bare, bare
    stale = set(UNASSERTED) - {where(p, l) for p, l, *_ in EXAMPLES}
    assert not stale, stale


# The commands CI runs itself, before this suite (.ci/run): the install and the tests.
INSTALL = ("cargo install", "cargo test", "python3 -m venv", "pip install", "python -m pytest")


def test_the_census_of_the_examples():
    """Every page's examples counted; what does not run is a stated exception."""
    c = census()
    assert c["blocks"] == c["run"] + c["not_run"]
    # Marked `not run:`: the benchmark and the scaling study's SciPy peers (`ros2 bag`
    # is prose beside the Python summary of the recording, which runs). The blocks
    # that do not run (2026-11-28: 3 of 40) are the install commands CI itself runs;
    # every other block runs, the live sessions against a simulator's PORT included.
    assert c["lines_marked_not_run"] <= 2, c
    assert c["not_run"] <= 3, c
    assert c["asserted"] == c["run"], c
    idle = [(where(page, line), cmd) for page, line, lang, body, _ in EXAMPLES if lang == "sh"
            and not any(runs(c) for c, _ in body) for cmd, _ in body if not any(k in cmd for k in INSTALL)]
    assert not idle, idle


def test_every_skip_is_used():
    """A SKIPPED entry no command line needs any more is stale."""
    lines = [c for e in EXAMPLES if e[2] == "sh" for c, _ in e[3]]
    assert not [key for key in SKIPPED if not any(key in c for c in lines)]


def test_the_readme_states_printed_answers():
    """The README's flagship examples carry their printed answers."""
    readme = [e for e in EXAMPLES if e[0].name == "README.md"]
    with_output = [e for e in readme if e[4]]
    assert len(with_output) >= 3, [(e[1], e[2]) for e in with_output]


SH = [e for e in EXAMPLES if e[2] == "sh" and any(runs(c) for c, _ in e[3])]


@pytest.fixture(scope="module")
def shims(cli, tmp_path_factory):
    """A folder put first on PATH: `fbgforge` (the command line CI built), `python`
    (this interpreter) and `fbgforge-studies` (the studies binary beside it)."""
    d = tmp_path_factory.mktemp("bin")
    studies = Path(cli.exe).with_name("fbgforge-studies")
    for name, target in (("fbgforge", cli.exe), ("python", sys.executable), ("fbgforge-studies", studies)):
        # A script, not a symlink: a venv's python finds its packages by the path it
        # was called by.
        (d / name).write_text(f'#!/bin/sh\nexec {shlex.quote(str(target))} "$@"\n')
        (d / name).chmod(0o755)
    return d


def as_run(cmd, comment):
    """The line as bash runs it here: a study through its binary (`--quick` when the
    docs say CI runs it so)."""
    if cmd == DEFAULT_BUILD:
        return "fbgforge"
    if cmd.startswith(STUDY):
        cmd = "fbgforge-studies" + cmd[len(STUDY):]
        if "CI: --quick" in comment and "--quick" not in cmd:
            cmd += " --quick"
    return cmd


def start_stream(cmd, env):
    """A `synth-stream --port 0` in the background, the port it says it serves, and
    what it printed up to there."""
    p = subprocess.Popen(["bash", "-c", "exec " + cmd], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True)
    seen = ""
    for line in p.stdout:
        seen += line
        m = re.search(r"127\.0\.0\.1:(\d+)|port (\d+)", line)
        if m:
            return p, m.group(1) or m.group(2), seen
    p.wait()
    raise AssertionError(f"`{cmd}` named no port:\n{seen}")


def stream_rest(proc):
    """What a stream printed after its port, once it stopped: its client is done, so it
    stops by itself when its frames are served; one still running after 5 s (a client
    that left early, a stream waiting for another) is stopped."""
    try:
        proc.wait(timeout=5)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
    return proc.stdout.read()


@pytest.mark.parametrize("page, line, lang, cmds, expected", SH, ids=[where(e[0], e[1]) for e in SH])
def test_every_shell_example_prints_what_the_docs_say(shims, page, line, lang, cmds, expected):
    env = {**os.environ, "PATH": f"{shims}{os.pathsep}{os.environ['PATH']}"}
    output, streams, stream, served = "", [], None, False
    try:
        for cmd, comment in cmds:
            if not runs(cmd) or cmd in SLOW:
                continue
            cmd = as_run(cmd, comment)
            if "synth-stream" in cmd and "--port 0" in cmd:
                stream, served = cmd, False
                proc, port, printed = start_stream(stream, env)
                streams.append(proc)
                output += printed
                continue
            client = stream is not None and "PORT" in cmd
            if client:
                if served:  # an alternative client: a stream of its own
                    proc, port, printed = start_stream(stream, env)
                    streams.append(proc)
                    output += printed
                cmd, served = cmd.replace("PORT", port), True
            # What the terminal shows: the report on stdout and the summaries on stderr.
            p = subprocess.run(["bash", "-o", "pipefail", "-c", cmd], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, timeout=900)
            # verify's exit status is its verdict (2 FAIL, 4 IN BAND, …): the printed
            # verdict is what the docs assert.
            ok = (0, 2, 3, 4, 5) if re.match(r"fbgforge verify\b", cmd) else (0,)
            assert p.returncode in ok, f"{where(page, line)}: `{cmd}` exited {p.returncode}\n{p.stdout}"
            output += p.stdout
            if client:
                output += stream_rest(proc)
    finally:
        for proc in streams:
            proc.kill()
            proc.wait()
            proc.stdout.close()
    if expected:
        assert_printed(expected, output, where(page, line))


PY = [e for e in EXAMPLES if e[2] == "python" and e[4]]


def interpreter(code):
    """The Python an example runs with: $FBGFORGE_PYTHON (the venv with the ROS 2
    world's MCAP readers, .ci/run) for a block that reads MCAP, else this one."""
    if "import mcap" in code or "from mcap" in code:
        py = os.environ.get("FBGFORGE_PYTHON")
        if not py:
            if os.environ.get("CI"):
                pytest.fail("FBGFORGE_PYTHON is not set (.ci/run sets it)")
            pytest.skip("needs FBGFORGE_PYTHON (the venv with mcap readers)")
        return py
    return sys.executable


@pytest.mark.parametrize("page, line, lang, code, expected", PY, ids=[where(e[0], e[1]) for e in PY])
def test_every_python_example_prints_what_the_docs_say(page, line, lang, code, expected, tmp_path):
    script = tmp_path / "example.py"
    script.write_text(code)
    p = subprocess.run([interpreter(code), str(script)], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, f"{where(page, line)}\n{p.stderr}"
    assert_printed(expected, p.stdout, where(page, line))


def cargo_tree(*args):
    p = subprocess.run(
        ["cargo", "tree", "--locked", "--offline", "--prefix", "none", "-f", "{p} [{f}]", *args],
        cwd=ROOT, capture_output=True, text=True, timeout=300,
    )
    assert p.returncode == 0, p.stderr
    return {line.replace(" (*)", "") for line in p.stdout.splitlines() if line.strip()}


@pytest.mark.skipif(shutil.which("cargo") is None, reason="needs cargo (CI has it)")
def test_the_install_compiles_nothing_the_tests_compile_again():
    """The README's two commands share one build: every crate the install compiles
    (`cargo install --path . --locked`: the facade's normal dependencies) has the same
    features in the tests' build (`cargo test --release`: every default member with its
    dev-dependencies), so Cargo reuses it. A dev-dependency that turns a feature on
    (criterion: serde's `alloc`; png: simd-adler32's `const-generics`) would make the
    second command compile that crate and everything above it again (45 crates before
    the facade named those features, Cargo.toml)."""
    install = cargo_tree("-p", "fbgforge", "-e", "normal,build")
    tests = cargo_tree("--workspace", "--exclude", "fbgforge-python", "-e", "normal,build,dev")
    assert install and install <= tests, sorted(install - tests)


if __name__ == "__main__":
    print(census())
