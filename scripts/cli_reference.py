"""docs/CLI.md: every command of ``shapegrowth`` with its arguments and options, generated
from the command line's own parser (shapegrowth/commands/cli.py), as CONFIG.md is from the
schema.

    .venv/bin/python scripts/cli_reference.py

tests/test_docs.py fails where the page is stale.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from shapegrowth.commands.cli import build_parser

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "CLI.md"

HEAD = """# The command line

Generated from the command line's parser by `scripts/cli_reference.py`; how to use the
commands together: [GUIDE.md](GUIDE.md) and [HOWTO.md](HOWTO.md); every config key:
[CONFIG.md](CONFIG.md); what a run writes: [OUTPUTS.md](OUTPUTS.md).

Exit status: 0 success, 2 bad input (one `error:` line per problem, naming the key and what
is allowed), 1 a run that failed (its `summary.json` says why in `status`, and the last
equilibrium reached is written). Every command runs unchanged under `mpirun -n N`.
"""


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:  # argparse keeps its subparsers there
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _helps(parser: argparse.ArgumentParser) -> dict[str, str]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return {a.dest: a.help or "" for a in action._choices_actions}
    return {}


def _name(action: argparse.Action) -> str:
    if not action.option_strings:
        return f"`{action.metavar or action.dest.upper()}`"
    flags = ", ".join(f"`{s}`" for s in action.option_strings)
    if action.nargs == 0:
        return flags
    metavar = action.metavar or action.dest.upper()
    return f"{flags} `{metavar}`"


def _usage(name: str, sub: argparse.ArgumentParser) -> str:
    """``shapegrowth NAME [OPTIONS] POSITIONALS``, written here rather than by argparse, whose
    usage lines differ from one Python release to the next."""
    words = [f"shapegrowth {name}"]
    for action in sub._actions:
        if isinstance(action, argparse._HelpAction):
            continue
        if not action.option_strings:
            metavar = action.metavar if isinstance(action.metavar, str) else None
            word = metavar or action.dest.upper()
            words.append(f"[{word}]" if action.nargs == "?" else word)
        elif action.required:
            words.append(f"{action.option_strings[0]} {action.metavar or action.dest.upper()}")
    if any(a.option_strings and not a.required for a in sub._actions
           if not isinstance(a, argparse._HelpAction)):
        words.insert(1, "[OPTIONS]")
    return " ".join(words)


def _row(action: argparse.Action) -> str:
    text = (action.help or "").replace("|", "/")
    if action.required and action.option_strings:
        text += " (required)"
    return f"| {_name(action)} | {text} |"


def markdown() -> str:
    parser = build_parser()
    out = [HEAD]
    helps = _helps(parser)
    for name, sub in _subcommands(parser).items():
        text = helps.get(name, "").rstrip(".")
        out += [f"## `shapegrowth {name}`", "", text[:1].upper() + text[1:] + ".", "",
                f"`{_usage(name, sub)}`", "", "| argument | meaning |", "|---|---|"]
        out += [_row(a) for a in sub._actions if not isinstance(a, argparse._HelpAction)]
        out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    PAGE.write_text(markdown())
    print(f"wrote {PAGE}")
