"""README's examples, and those of the guide it links to, print what they say: their Python blocks
run in order in one namespace and the values shown in their comments come back; the CLI examples
shown with output print it.

The values in README were measured on this project's machine; numbers are compared to the digits
README shows (one unit in the last shown digit; values below 1e-4, the rounding at onset's double root, as zero).
"""

from __future__ import annotations

import ast
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).parents[1] / "README.md"
#: README's tour continues in the guide's pages, in this order (docs/guide/index.md): one text, one namespace.
GUIDE = ("models", "stability", "fe-models", "uncertainty", "transient", "measurement", "correlation", "scale",
         "fe-brake", "design", "command-line", "speed", "layout")
TEXT = "\n".join(p.read_text(encoding="utf-8") for p in
                 (README, *(README.parent / "docs" / "guide" / f"{name}.md" for name in GUIDE)))

# Blocks too slow for every CI run; each is checked by its own module's tests instead:
# squeal_propensity (tests/test_uncertainty.py), limit_cycle_branch (tests/test_nonlinear.py),
# the FE demo at its default size and its reduction (tests/test_fe_demo.py, tests/test_reduction.py), a Dask
# cluster. The coarse demo (n_theta=8, 738 DOFs: about 1 s) runs.
SLOW_PY = ("squeal_propensity(", "limit_cycle_branch(", "build_fe_demo(n_theta=48", "reduced_sweep", "tcp://HOST")
# CLI examples not run: a cluster or campaign, a correlation (it reads a campaign's results;
# tests/test_correlate.py), a shell pipe or variable, the whole report, limit cycles
# (tests/test_nonlinear.py), placeholders in brackets.
SLOW_CLI = ("campaign", "correlate", "reproduce", "limitcycle", "duckdb", "|", "=1 squealkit", "[")

_NUM = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def _numbers(text: str) -> list[str]:
    """The numbers written in ``text`` (quoted strings and identifiers like k1 left out)."""
    text = re.sub(r"'[^']*'|\"[^\"]*\"", " ", text)
    word = tuple("abcdefghijklmnopqrstuvwxyz_")
    return [m.group() for m in _NUM.finditer(text) if not text[: m.start()].endswith(word)]


def _close(shown: str, value: float) -> bool:
    """``value`` printed with ``shown``'s digits reads as ``shown`` (one unit in its last digit)."""
    mant, _, exp = shown.lower().partition("e")
    decimals = len(mant.split(".")[1]) if "." in mant else 0
    ulp = 10.0 ** (-decimals) * (10.0 ** int(exp) if exp else 1.0)
    b = float(shown)
    if abs(b) < 1e-4 and abs(value) < 1e-4:
        return True  # rounding-size values: growth rate, zeta and friction work at the double root of onset
    return abs(value - b) <= 1.01 * ulp


def _flatten(value) -> list[float]:
    if isinstance(value, dict):
        return [x for v in value.values() for x in _flatten(v)]
    if isinstance(value, str | bytes) or value is None:
        return []
    if isinstance(value, complex | np.complexfloating):
        return [float(value.real), float(value.imag)]
    if isinstance(value, bool | np.bool_):
        return []
    if isinstance(value, int | float | np.number):
        return [float(value)]
    if isinstance(value, tuple | list | np.ndarray):
        return [x for v in np.asarray(value, dtype=object).ravel().tolist() for x in _flatten(v)]
    return []


def _python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", TEXT, flags=re.S)


def _comment_of(lines: list[str], node) -> str:
    """The value README shows for an expression statement: its trailing comment, or a comment line below."""
    end = node.end_lineno
    line = lines[end - 1]
    comment = line.split("#", 1)[1] if "#" in line else ""
    if not comment.strip() and end < len(lines) and lines[end].lstrip().startswith("#"):
        comment = lines[end].lstrip()[1:]
    comment = re.sub(r"\[truth[^\]]*\]", "", comment.strip())  # the synthetic truth beside a value
    return comment if comment[:1].isdigit() or comment[:1] in "[({'-+" else ""


@pytest.mark.slow
def test_readme_python_blocks_run_and_show_their_values(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(README.parent / "examples")
    ns: dict = {}
    checked = 0
    for i, block in enumerate(_python_blocks()):
        if any(s in block for s in SLOW_PY):
            continue
        lines = block.splitlines()
        for node in ast.parse(block).body:  # statement by statement: a value is checked where it is shown
            comment = _comment_of(lines, node) if isinstance(node, ast.Expr) else ""
            with _no_fail():
                if not comment:
                    exec(compile(ast.Module([node], []), f"README python block {i}", "exec"), ns)
                    continue
                value = eval(compile(ast.Expression(node.value), f"README python block {i}", "eval"), ns)
            src = ast.get_source_segment(block, node)
            got = _flatten(value)
            head = comment if comment.startswith("[") else comment.split(";")[0].split(": ")[0]
            shown = _numbers(head)[: len(got)]
            assert len(shown) == len(got) and all(_close(s, v) for s, v in zip(shown, got, strict=True)), (
                f"README block {i}: {src} gives {value!r}, README shows # {comment}")
            for word in re.findall(r"'([^']*)'", head):
                assert word in repr(value), f"README block {i}: {src} gives {value!r}, README shows # {comment}"
            checked += 1
    assert checked >= 15


class _no_fail:
    """Warnings README's examples draw (censoring, tensile contact) are shown, not errors."""

    def __enter__(self):
        import warnings

        self._cm = warnings.catch_warnings()
        self._cm.__enter__()
        warnings.simplefilter("ignore")

    def __exit__(self, *exc):
        return self._cm.__exit__(*exc)


def _console_examples():
    """(command args, shown output lines) of README's console blocks that show output."""
    out = []
    for block in re.findall(r"```console\n(.*?)```", TEXT, flags=re.S):
        cmd, shown = None, []
        for line in [*block.replace("\\\n", " ").splitlines(), "$ end"]:
            if line.startswith("$ "):
                if cmd is not None and shown and not any(s in cmd for s in SLOW_CLI):
                    out.append((cmd, shown))
                cmd, shown = line[2:].split("#")[0].strip(), []
            elif line.strip():
                shown.append(line)
    return out


CLI_EXAMPLES = _console_examples()
#: Model files the pages give whole, headed by their name alone (```toml, then ``# design.toml``): written
#: where the CLI examples run, as the reader would save them.
FILES = re.findall(r"```toml\n# ([\w./-]+\.toml)\n(.*?)```", TEXT, flags=re.S)


@pytest.mark.slow
def test_readme_cli_examples_print_what_readme_shows(tmp_path, monkeypatch):
    from click.testing import CliRunner

    from squealkit.cli.main import cli

    monkeypatch.chdir(tmp_path)
    for name, content in FILES:
        (tmp_path / name).write_text(content, encoding="utf-8")
    assert len(CLI_EXAMPLES) >= 10
    for cmd, shown in CLI_EXAMPLES:
        args = shlex.split(cmd)
        assert args[0] == "squealkit", cmd
        r = CliRunner().invoke(cli, args[1:], prog_name="squealkit")
        out, err = r.stdout.splitlines(), r.stderr.splitlines()
        pos = 0
        for want in shown:
            if want.strip() == "...":
                continue
            prefix = want.endswith("...")
            want_text = want[:-3] if prefix else want
            if want.startswith("squealkit:"):  # stderr: warnings and errors, beside stdout
                if not any(_line_matches(want_text, g, prefix) for g in err):
                    pytest.fail(f"README: `{cmd}` should say on stderr\n  {want}\nbut said:\n" + "\n".join(err))
                continue
            for j in range(pos, len(out)):
                if _line_matches(want_text, out[j], prefix):
                    pos = j + 1
                    break
            else:
                pytest.fail(f"README: `{cmd}` should print\n  {want}\nbut printed:\n" + "\n".join(out))


def _line_matches(want: str, got: str, prefix: bool) -> bool:
    if prefix:
        got = got[: len(want) + 40]
    w_nums, g_nums = _numbers(want), _numbers(got)
    w_text = _NUM.sub("#", re.sub(r"\s+", " ", want.strip()))
    g_text = _NUM.sub("#", re.sub(r"\s+", " ", got.strip()))
    if prefix:
        g_text = g_text[: len(w_text)]
        g_nums = g_nums[: len(w_nums)]
    return (w_text == g_text and len(w_nums) == len(g_nums)
            and all(_close(w, float(g)) for w, g in zip(w_nums, g_nums, strict=True)))
