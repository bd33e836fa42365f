"""Shared fixtures of the Python tests: the repository's paths, the command line (for
round trips against its JSON), a synthetic log pair with known K, and a comparison of
JSON documents in which the command line's null is the binding's NaN."""

import json
import math
import os
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
DESIGNS = ROOT / "designs"
FIXTURES = ROOT / "fixtures"
ARRAY = DESIGNS / "tactile-array-60x80.toml"
MODULE = DESIGNS / "clip-on-34mm.toml"


@pytest.fixture(autouse=True)
def _at_root(monkeypatch):
    """Run every test (and every doctest) from the repository root, where the docs'
    relative paths (designs/, fixtures/) hold."""
    monkeypatch.chdir(ROOT)


@pytest.fixture(scope="session")
def cli():
    """The fbgforge command line: $FBGFORGE_BIN, or the release build `cargo test
    --release` made (built here if missing)."""
    exe = os.environ.get("FBGFORGE_BIN") or str(ROOT / "target" / "release" / "fbgforge")
    if not Path(exe).exists():
        subprocess.run(["cargo", "build", "--release", "--bin", "fbgforge"], cwd=ROOT, check=True)

    def run(*args, ok_codes=(0,)):
        p = subprocess.run([exe, *map(str, args)], cwd=ROOT, capture_output=True, text=True)
        assert p.returncode in ok_codes, f"{args}: {p.returncode}\n{p.stderr}"
        return p

    run.exe = exe
    return run


def cli_json(cli, *args, ok_codes=(0,)):
    return json.loads(cli(*args, ok_codes=ok_codes).stdout)


def in_python_words(doc):
    """`doc` (the command line's text or JSON document) with its flags named as the
    Python parameters are (`--date-order` → `date_order`), as the package says them."""
    if isinstance(doc, str):
        return re.sub(r"(?<![\w-])--([a-z][a-z0-9-]*)", lambda m: m.group(1).replace("-", "_"), doc)
    if isinstance(doc, dict):
        return {k: in_python_words(v) for k, v in doc.items()}
    if isinstance(doc, list):
        return [in_python_words(v) for v in doc]
    return doc


def cli_error(cli, *args):
    """The message the command line prints after `error: `, exit status 1, with its
    flags named as the Python parameters are (`--date-order` → `date_order`)."""
    p = cli(*args, ok_codes=(1,))
    line = p.stderr.strip().splitlines()[-1]
    assert line.startswith("error: "), p.stderr
    return in_python_words(line[len("error: "):])


def close(got, want, rel=1e-9, path="$"):
    """`got` (the binding's document) equals `want` (the command line's JSON), floats
    to a relative tolerance, a NaN where the JSON has null."""
    if isinstance(want, dict):
        assert isinstance(got, dict) and got.keys() == want.keys(), f"{path}: keys {got.keys()} vs {want.keys()}"
        for k in want:
            close(got[k], want[k], rel, f"{path}.{k}")
    elif isinstance(want, list):
        assert isinstance(got, (list, tuple)) and len(got) == len(want), f"{path}: lengths"
        for i, (x, y) in enumerate(zip(got, want)):
            close(x, y, rel, f"{path}[{i}]")
    elif want is None:
        assert got is None or (isinstance(got, float) and math.isnan(got)), f"{path}: {got!r} vs null"
    elif isinstance(want, float) or isinstance(got, float):
        assert got is not None, f"{path}: None vs {want}"
        assert math.isclose(got, want, rel_tol=rel, abs_tol=1e-12), f"{path}: {got} vs {want}"
    else:
        assert got == want, f"{path}: {got!r} vs {want!r}"


def no_none_in_numbers(doc, path="$"):
    """No None where the library has a number: NaN instead (a dict key whose every
    sibling row holds a float may not hold None). Checks lists of floats."""
    if isinstance(doc, dict):
        for k, v in doc.items():
            no_none_in_numbers(v, f"{path}.{k}")
    elif isinstance(doc, list):
        if any(isinstance(x, float) for x in doc):
            assert all(x is not None for x in doc), f"{path}: None inside a list of numbers"
        for i, x in enumerate(doc):
            no_none_in_numbers(x, f"{path}[{i}]")


@pytest.fixture(scope="session")
def synth_logs(tmp_path_factory):
    """A synthetic log pair with known K = 12 pm/N."""
    import fbgforge

    out = tmp_path_factory.mktemp("synth")
    fbgforge.synth_log(MODULE, out, k_pm_per_n=12.0, rate_hz=10)
    return out
