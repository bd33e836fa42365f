"""The documentation's examples are tests of their output, not only of running.

Every command line of a ```sh block in README.md, docs/python.md and the user guide
(docs/guide/) that calls `fbgforge` or `python -c` runs here as written, from the
repository root, with the command line CI built; every ```python block of those pages
runs too (test_docs.py). When an example block is followed directly (only blank lines
between) by a ```text block, that block is the example's printed answer and is
asserted:

* each of its lines must appear, in order, among the lines the example printed (the
  example may print more lines than the docs show: abridged output is allowed);
* `…` stands for any text; runs of spaces match any run of spaces (tables align);
* every number of the expected line must be printed within **1 % or one unit of its
  last shown digit, whichever is larger** (`11.998` matches 11.99–12.01 and
  11.88–12.12 by the 1 %; `Q 249.36` matches 246.9–251.9; an integer `67` matches
  66–68): the docs round, the machines differ in the last bits, a model change that
  moves an answer fails.

Commands that cannot run on a fresh clone (they name the reader's own files, a port
a simulator picks, or are the install commands CI itself runs) are listed in SKIPPED
with the reason, and the test fails on a command that is neither run nor listed, so a
new example cannot go unchecked by accident.

Why this and not trycmd/snapbox: the examples are half Python, and pytest already
runs them with the installed package and the command line CI built (test_docs.py);
trycmd would check the shell half only, in a second harness, and compares numbers as
text (a `[..]` wildcard in place of a number asserts nothing about it), where the
docs' claims are numbers with a tolerance.
"""

import math
import shutil
import re
import shlex
import subprocess
import sys

import pytest

from conftest import ROOT

PAGES = [ROOT / "README.md", ROOT / "docs" / "python.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]

# Command lines not run, with the reason (the test below fails on any other).
SKIPPED = {
    "cargo install": "the install itself: .ci/run runs `cargo install --path . --locked` before the tests",
    "cargo test": "the test command itself (.ci/run)",
    "cargo run": "the studies and the default build, run by `cargo test --release` (studies/tests) and by `fbgforge` here",
    "python3 -m venv": "the package's install: .ci/run makes the venv and installs it as written",
    "pip install": "the package's install (.ci/run)",
    "python -m pytest": "this very test suite",
    "PORT": "a port the simulator picks when it starts: tests/array/live*.rs run synth-stream and live together",
    "Peaks.2025": "the reader's own interrogator log (docs/guide/verify.md and live.md show its shape; fixtures/ hold real ones, tested in tests/verify)",
    "--matrix A.csv": "the reader's own matrix and shifts (the README's reconstruct example runs on the fixtures)",
    "--shifts shifts.csv": "the reader's own shifts (the README's reconstruct example runs on the fixtures)",
}

# Commands too slow for CI, with the test that asserts their output instead (none:
# the slowest, `optimize` of the 16 mm module and the README's 81-step Case I sweep,
# take 7 s of CPU each).
SLOW = {}


def blocks(path):
    """The fenced blocks of a page, in order: (line, language, code)."""
    text = path.read_text()
    out = []
    for m in re.finditer(r"^```([\w-]*)[^\n]*\n(.*?)^```[ \t]*$", text, re.S | re.M):
        out.append((text[: m.start()].count("\n") + 1, m.group(1), m.group(2), m.start(), m.end()))
    return out, text


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
                cmds = []
                for k, cmd in enumerate(re.sub(r"\\\n\s*", " ", code).splitlines()):
                    cmd = cmd.split("  #")[0].strip()
                    if cmd and not cmd.startswith("#"):
                        cmds.append(cmd)
                out.append((page, line, lang, cmds, expected))
            else:
                out.append((page, line, lang, code, expected))
    return out


EXAMPLES = examples()


# The programs an example line may call: fbgforge, Python, and `head`/`cat` to show a
# file a command wrote.
RUNNABLE = ("fbgforge", "python", "head", "cat")


def skip_reason(cmd):
    for key, why in SKIPPED.items():
        if key in cmd:
            return why
    return None


def number_close(expected, actual):
    """`actual` within 1 % of `expected` or one unit of its last shown digit."""
    e, a = float(expected), float(actual)
    decimals = len(expected.split(".")[1].split("e")[0].split("E")[0]) if "." in expected else 0
    return abs(a - e) <= max(0.01 * abs(e), 10.0 ** -decimals) + 1e-12


NUMBER = r"[-+−]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?"


def tokens(expected):
    """One expected line as tokens: ("num", text), ("any",), ("ws",), ("lit", text)."""
    # Spaces beside a `…` belong to it (`FAIL …` matches a line ending in FAIL).
    expected = re.sub(r"\s*…\s*", "…", expected.strip())
    out = []
    for tok in re.split(rf"(…|{NUMBER}|\s+)", expected):
        if not tok:
            continue
        if tok == "…":
            out.append(("any",))
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
    with pytest.raises(AssertionError):
        assert_printed(["b 2", "a 1"], "a 1\nb 2", "order")


def test_every_example_is_run_or_its_skip_stated():
    """No command of the docs goes unchecked without a stated reason."""
    for page, line, lang, body, _ in EXAMPLES:
        if lang != "sh":
            continue
        for cmd in body:
            runnable = cmd.split()[0] in RUNNABLE
            assert runnable or skip_reason(cmd), f"{page.name}:{line}: `{cmd}` is neither run nor skipped with a reason"


def test_the_readme_states_printed_answers():
    """The README's flagship examples carry their printed answers."""
    readme = [e for e in EXAMPLES if e[0].name == "README.md"]
    with_output = [e for e in readme if e[4]]
    assert len(with_output) >= 3, [(e[1], e[2]) for e in with_output]


SH = [e for e in EXAMPLES if e[2] == "sh" and any(c.split()[0] in RUNNABLE and not skip_reason(c) for c in e[3])]


@pytest.mark.parametrize("page, line, lang, cmds, expected", SH, ids=[f"{e[0].name}:{e[1]}" for e in SH])
def test_every_shell_example_prints_what_the_docs_say(cli, page, line, lang, cmds, expected):
    output = ""
    for cmd in cmds:
        if skip_reason(cmd) or cmd in SLOW or cmd.split()[0] not in RUNNABLE:
            continue
        args = shlex.split(cmd)
        args[0] = {"fbgforge": cli.exe, "python": sys.executable}.get(args[0], args[0])
        # What the terminal shows: the report on stdout and the summaries on stderr.
        p = subprocess.run(args, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=900)
        # verify's exit status is its verdict (2 FAIL, 4 IN BAND, …): the printed
        # verdict is what the docs assert.
        ok = (0, 2, 3, 4, 5) if args[1:2] == ["verify"] else (0,)
        assert p.returncode in ok, f"{page.name}:{line}: `{cmd}` exited {p.returncode}\n{p.stdout}"
        output += p.stdout
    if expected:
        assert_printed(expected, output, f"{page.name}:{line}")


PY = [e for e in EXAMPLES if e[2] == "python" and e[4]]


@pytest.mark.parametrize("page, line, lang, code, expected", PY, ids=[f"{e[0].name}:{e[1]}" for e in PY])
def test_every_python_example_prints_what_the_docs_say(page, line, lang, code, expected, tmp_path):
    script = tmp_path / "example.py"
    script.write_text(code)
    p = subprocess.run([sys.executable, str(script)], cwd=ROOT, capture_output=True, text=True, timeout=900)
    assert p.returncode == 0, f"{page.name}:{line}\n{p.stderr}"
    assert_printed(expected, p.stdout, f"{page.name}:{line}")


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
