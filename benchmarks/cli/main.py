"""The ``scenesim`` console script: one parser, one sub-command module each.

Each module in ``_COMMANDS`` defines ``add_parser(subparsers)`` that registers its
sub-command and sets ``func(args) -> int`` as the handler.  The CLI lives in the top
layer (benchmarks) so that it may import every package without the lower layers
importing upward.
"""

from __future__ import annotations

import os

# Deterministic warm-up arrays (babble bank, bias-compensation tables, RIRs) are cached on
# disk for the command-line app only: library calls stay memory-only unless the caller sets
# $SCENESIM_CACHE.  SCENESIM_CACHE= (empty) disables the disk cache; a user's own value wins.
os.environ.setdefault(
    "SCENESIM_CACHE",
    os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
                 "scenesim"),
)

# Our parallelism is one process per worker; a multi-threaded BLAS in each would
# oversubscribe the cores.  Set before numpy is first imported; a user's own setting wins.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import importlib  # noqa: E402
import re  # noqa: E402
import sys  # noqa: E402

from benchmarks.cli.checks import CREATED, remove_created_dirs  # noqa: E402
from benchmarks.cli.console import cli_warnings  # noqa: E402
from scenesim.errors import ScenesimError  # noqa: E402

_COMMANDS = ("bench", "simulate", "enhance", "score", "data", "rir", "plugin", "tune", "thesis", "listen")


def _version() -> str:
    from scenesim import __version__

    return __version__


def build_parser(commands: tuple[str, ...] = _COMMANDS) -> argparse.ArgumentParser:
    """The parser with the sub-commands ``commands`` (default: all of them).

    >>> sorted(build_parser(("rir",))._subparsers._group_actions[0].choices)
    ['rir']
    """
    parser = argparse.ArgumentParser(
        prog="scenesim",
        description="Simulate hands-free phone scenes and benchmark speech enhancers.",
    )
    parser.add_argument("--version", action="version", version=f"scenesim {_version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name in commands:
        importlib.import_module(f"benchmarks.cli.{name}").add_parser(sub)
    return parser


def _attach_negative_values(argv: list[str]) -> list[str]:
    """``--opt -1,0`` -> ``--opt=-1,0``: argparse reads a value starting with '-' that is not a
    plain number as an option ("expected one argument"); joined, the option's own check names it.

    >>> _attach_negative_values(["enhance", "--channels", "-1,0", "x.wav"])
    ['enhance', '--channels=-1,0', 'x.wav']
    """
    out: list[str] = []
    for token in argv:
        # Plain negative numbers argparse reads as values already (and nargs options need them apart).
        plain = re.fullmatch(r"-\d+|-\d*\.\d+", token)
        if out and out[-1].startswith("--") and "=" not in out[-1] and not plain and re.fullmatch(r"-\d[\d.,eE+-]*", token):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def _commands_for(argv: list[str]) -> tuple[str, ...]:
    """Only the sub-command typed, when it is the first word: importing every sub-command's
    module costs ~1.5 s CPU (``simulate`` pulls in scipy.signal), more than a short command
    itself.  Anything else (``--help``, a typo) gets them all, so argparse can list them.

    >>> _commands_for(["bench", "report", "DIR"]), len(_commands_for(["--help"])) == len(_COMMANDS)
    (('bench',), True)
    """
    return (argv[0],) if argv and argv[0] in _COMMANDS else _COMMANDS


def main(argv: list[str] | None = None) -> int:
    argv = _attach_negative_values(sys.argv[1:] if argv is None else list(argv))
    args = build_parser(_commands_for(argv)).parse_args(argv)
    CREATED.clear()  # only this command's own directories are removed when it is refused
    try:
        with cli_warnings():
            return int(args.func(args) or 0)
    except ScenesimError as exc:
        # Our own errors are user-facing: one clear line, no traceback; and nothing left behind.
        remove_created_dirs()
        print(f"scenesim: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:  # a file-system refusal the commands did not foresee: still one line
        remove_created_dirs()
        where = f": {exc.filename}" if exc.filename else ""
        print(f"scenesim: error: {exc.strerror or exc}{where}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as exc:  # a sweep's RunInterrupted says what is kept and how to resume
        print(f"scenesim: {str(exc) or 'interrupted'}", file=sys.stderr)
        return getattr(exc, "exit_code", 130)


if __name__ == "__main__":
    sys.exit(main())
