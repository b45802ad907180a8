"""Every ``$ squealkit ...`` command the documentation shows parses as the CLI defines it.

The README's and the guide's commands that show output are run in full by tests/test_readme.py;
the how-tos and the rest show commands without output (a whole report, a campaign, a cluster),
too slow to run on every CI run. Each is parsed here by the command itself (click: every option
exists, every required one is given, every value has its type), in a folder where the files the
command names exist, so a how-to cannot teach a command that fails at once.
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import click
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
#: Placeholders a reader replaces (a scheduler's address, a bracketed choice).
PLACEHOLDERS = ("HOST", "[", "<", "...")


def _commands() -> list[tuple[str, str, str | None]]:
    """(page, command, the error the page shows it giving, if it shows one) of every shown command."""
    found = []
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        for block in re.findall(r"```(?:console|bash)\n(.*?)```", text, flags=re.S):
            lines = block.replace("\\\n", " ").splitlines()
            for i, line in enumerate(lines):
                shown = lines[i + 1] if i + 1 < len(lines) else ""
                error = shown.split("error: ", 1)[1] if shown.startswith("squealkit: error: ") else None
                line = line.removeprefix("$ ").split(" #")[0].strip()
                for part in re.split(r"&&|;|\|", line):
                    part = part.strip()
                    if part.startswith("squealkit ") and not any(p in part for p in PLACEHOLDERS):
                        found.append((page.relative_to(ROOT).as_posix(), part, error))
    return found


COMMANDS = _commands()


def test_the_documentation_shows_commands():
    pages = {page for page, _, _ in COMMANDS}
    assert len(COMMANDS) >= 30 and "docs/howto.md" in pages, pages


@pytest.mark.parametrize(("page", "command", "error"), COMMANDS, ids=[f"{p}:{c[:60]}" for p, c, _ in COMMANDS])
def test_documented_command_parses(page, command, error, tmp_path, monkeypatch):
    from squealkit.cli.main import cli

    monkeypatch.chdir(tmp_path)
    args = shlex.split(command)[1:]
    for a in args:  # the files a command reads: present (their content is not read while parsing)
        if re.search(r"\.(toml|csv|tdms|nc|wav|mf4|uff|mat|mtx|op4)$", a) and "=" not in a:
            src = ROOT / "examples" / Path(a).name
            Path(a).parent.mkdir(parents=True, exist_ok=True)
            if not Path(a).exists():
                Path(a).write_bytes(src.read_bytes() if src.exists() else b"")
    try:
        with cli.make_context("squealkit", args) as ctx:  # the group's own options (--threads) first
            rest = [*(getattr(ctx, "_protected_args", None) or ctx.protected_args), *ctx.args]
            name, sub, sub_args = cli.resolve_command(ctx, rest)
            sub.make_context(f"squealkit {name}", sub_args, parent=ctx)
    except click.UsageError as e:
        if error is None or not error.startswith(e.format_message()):
            pytest.fail(f"{page}: `{command}` does not parse: {e.format_message()}")
    # a shown error the parser does not raise comes from the run: tests/test_readme.py runs those
