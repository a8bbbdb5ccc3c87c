"""The argument parser: the program's options, then each command's (its module's ``add_parser``)."""

from __future__ import annotations

import argparse
import re

from .errors import ERROR_PREFIX
from .progress import terminal_columns
from . import batch, gosselin, ik, map as map_command, singular, solve, track, verify


class HelpFormatter(argparse.HelpFormatter):
    """argparse's help formatter with the width read by :func:`terminal_columns`.

    argparse builds a formatter for every option added (to check its metavar), and its default
    width imports shutil (with bz2, lzma, zlib: ~1.5 ms, paid by every process, benchmarks/bench_process.py)
    only to read the terminal's width; the help printed is the same.
    """

    def __init__(self, prog, indent_increment=2, max_help_position=24, width=None):
        super().__init__(prog, indent_increment, max_help_position,
                         terminal_columns() - 2 if width is None else width)


#: What `spherekin --help` says spherekin is (the commands follow, listed by argparse).
DESCRIPTION = ("Direct kinematics of parallel spherical mechanisms with Bernstein polynomials: every "
               "assembly of a mechanism inside its joint ranges, each one proven.")


class Parser(argparse.ArgumentParser):
    """argparse's parser with spherekin's one error format: a usage error is the line
    "spherekin: error: --option: expected ..., got ... (see spherekin COMMAND --help)", exit status 2,
    instead of argparse's usage block and its "spherekin COMMAND: error:" line. The command parsers
    are of this class too (add_subparsers makes its parsers of the parser's own class)."""

    def add_subparsers(self, **kwargs):
        self._commands = super().add_subparsers(**kwargs)
        return self._commands

    def command(self, name: str | None) -> "Parser":
        """The parser of command ``name`` (this parser when it has no such command)."""
        commands = getattr(self, "_commands", None)
        return commands.choices.get(name, self) if commands is not None and name else self

    def parse_args(self, args=None, namespace=None):
        # argparse reports a command's stray arguments from the top parser; the command's own parser
        # says it here, so that the hint names the command's --help
        namespace, extras = self.parse_known_args(args, namespace)
        if extras:
            self.command(getattr(namespace, "command", None)).error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace

    def error(self, message):
        self.exit(2, f"{ERROR_PREFIX}{self.usage_error(message)} (see {self.prog} --help)\n")

    def options(self) -> dict[str, str]:
        """Python name -> the option that sets it, as typed (its long form), for every option of this
        parser: ``workers`` -> "--workers", ``chunk_size`` -> "--chunk-size" (each command its own)."""
        return {a.dest: max(a.option_strings, key=len) for a in self._actions if a.option_strings}

    def usage_error(self, message: str) -> str:
        """argparse's error ``message`` in spherekin's words: "argument --jobs: invalid int value:
        'x'" -> "--jobs: expected a whole number, got 'x'"; the command list for a missing or unknown
        command. Messages it does not know are kept."""
        commands = getattr(self, "_commands", None)
        names = ", ".join(commands.choices) if commands is not None else ""
        m = re.fullmatch(r"argument (?P<name>[^:]+): (?P<rest>.*)", message, re.S)
        if m:
            name, rest = m["name"].split("/")[-1], m["rest"]
            choice = re.fullmatch(r"invalid choice: (?P<value>.+?) \(choose from (?P<choices>.*)\)", rest, re.S)
            if commands is not None and name in (commands.dest, commands.metavar) and choice:
                return f"{choice['value']} is not a command; expected one of {names}"
            for pattern, words in ((r"invalid int value: (.+)", "expected a whole number, got {}"),
                                   (r"invalid float value: (.+)", "expected a number, got {}"),
                                   (r"expected one argument", "expected a value"),
                                   (r"expected (\d+) arguments?", "expected {} values"),
                                   (r"ignored explicit argument (.+)", "takes no value, got {}")):
                found = re.fullmatch(pattern, rest, re.S)
                if found:
                    rest = words.format(*found.groups())
                    break
            if choice:
                rest = (f"expected one of {', '.join(c.strip(chr(39)) for c in choice['choices'].split(', '))}, "
                        f"got {choice['value']}")
            return f"{name}: {rest}"
        m = re.fullmatch(r"the following arguments are required: (?P<names>.*)", message, re.S)
        if m:
            missing = m["names"].split(", ")
            if commands is not None and (commands.dest in missing or commands.metavar in missing):
                return f"expected a command, one of {names}"
            return f"{' and '.join(missing)}: required, not given"
        m = re.fullmatch(r"unrecognized arguments: (?P<args>.*)", message, re.S)
        if m:
            return f"{m['args']}: not an option or argument of {self.prog}"
        m = re.fullmatch(r"ambiguous option: (?P<option>\S+) could match (?P<matches>.*)", message, re.S)
        if m:
            return f"{m['option']}: ambiguous, could be {m['matches']}"
        return message


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = Parser(prog="spherekin", description=DESCRIPTION, formatter_class=HelpFormatter,
                     epilog="'spherekin COMMAND --help' gives the options of a command; docs/howto/ has examples.")
    parser.add_argument("--version", action="version", version=f"spherekin {__version__}")
    commands = parser.add_subparsers(dest="command", required=True, title="commands", metavar="COMMAND")

    def sub_add_parser(name, **kw):
        return commands.add_parser(name, formatter_class=HelpFormatter, **kw)
    for command in COMMANDS:
        command.add_parser(sub_add_parser)
    return parser


#: The commands in the order ``spherekin --help`` lists them.
COMMANDS = (solve, ik, batch, map_command, singular, track, gosselin, verify)
