"""The application: the ``mprt`` command, apart from the library it drives.

Nothing in the library imports this package (tests/test_layers.py checks it).  Here:
``build_parser`` and ``main`` (Ctrl-C, exit statuses); ``render`` (scene, render, trace,
stats), ``simulate`` and ``fidelity`` (simulate and its ladder options), ``explore`` and
``sweep`` (explore, prepass, sweep), ``calibrate`` (``python -m mprt.cli.calibrate``), and
their helpers: ``options`` (every option, validated once), ``progress`` (phase lines and
bars on stderr), ``report`` (the self-contained HTML report pages).

Every subcommand follows the same rules (``mprt.cli.options`` holds the shared
parts): each option is validated once with its range in the message and in
``--help``; nothing asked for is silently replaced; outputs are checked before
any work, and messages name the user's paths; JSON outputs carry the settings
that made them and the wall time.  Exit status: 0 done, 1 an error during the
work (a malformed scene file, a damaged trace, ...), 2 a bad option, scene name
or output path, found before any work.
"""
from __future__ import annotations

import argparse
import os
import signal
import sys
import threading

from . import options
from .render import EPILOG, _add_render, _add_scene, _add_stats, _add_trace  # noqa: F401
from ..errors import MprtError
from .options import UsageError


# -- the parser ---------------------------------------------------------------------------------
COMMANDS = ("scene", "render", "trace", "stats", "simulate", "explore", "prepass", "sweep")
EXPLORE_COMMANDS = ("explore", "prepass", "sweep")


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The ``mprt`` parser.  ``only``: just that command's parser (what ``main`` builds for a
    command line naming one), without the other commands' imports: the machine model's and the
    fidelity ladder's for ``simulate`` (about 70 ms), the explorer's for ``explore``, ``prepass``
    and ``sweep`` (tens of ms, one parser for the three)."""
    p = argparse.ArgumentParser(prog="mprt", description="3MPRT ray-tracing machine explorer", epilog=EPILOG)
    p.add_argument("--version", action="version", version=f"mprt {options.version()}")
    sub = p.add_subparsers(dest="cmd", required=True, metavar="COMMAND")
    for names, add in ((("scene",), _add_scene), (("render",), _add_render), (("trace",), _add_trace),
                       (("stats",), _add_stats), (("simulate",), _add_simulate), (EXPLORE_COMMANDS, _add_explore)):
        if only is None or only in names:
            add(sub)
    return p


def _add_simulate(sub) -> None:
    from .fidelity import add_parser

    add_parser(sub)


def _add_explore(sub) -> None:
    from .explore import add_parsers

    add_parsers(sub)


def _interrupt_once() -> None:
    """Ctrl-C (SIGINT) raises KeyboardInterrupt once, as Python's own handler does; a second
    one, while the command unwinds (temporaries removed, worker processes ended), ends the
    process at once, silently (what it leaves is then only temporaries named for the next
    run to remove: ``atomic``)."""
    def handler(signum, frame):
        signal.signal(signal.SIGINT, signal.SIG_DFL)
        raise KeyboardInterrupt
    signal.signal(signal.SIGINT, handler)


def _from_interrupt(e: BaseException) -> bool:
    """Whether the error came of a KeyboardInterrupt (its cause or context, at any depth)."""
    seen = set()
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return True
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return False


def main(argv=None) -> int:
    """The ``mprt`` command line (``argv``: the arguments, default sys.argv's); returns the exit
    status.  Ctrl-C in any command is one line on stderr and status 130."""
    program = argv is None and threading.current_thread() is threading.main_thread() and \
        signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if not program:             # a caller in-process keeps its own handler
        return _main(argv)
    _interrupt_once()
    try:
        return _main(argv)
    finally:    # the work is done: a Ctrl-C while the interpreter exits ends it at once, silently
        signal.signal(signal.SIGINT, signal.SIG_DFL)


def _main(argv) -> int:
    argv = sys.argv[1:] if argv is None else [str(v) for v in argv]
    try:
        parser = build_parser(only=argv[0] if argv[:1] and argv[0] in COMMANDS else None)
        args = parser.parse_args(argv)
    except KeyboardInterrupt:     # while the command's modules were imported
        print("mprt: interrupted", file=sys.stderr)
        return 130
    args.argv = argv
    try:
        try:
            rc = args.func(args)
        except Exception as e:    # a Ctrl-C that a library turned into another error (an NLopt callback's)
            if _from_interrupt(e):
                raise KeyboardInterrupt from e
            raise
        sys.stdout.flush()        # here, not at exit: a reader gone by now is caught below
        return rc
    except UsageError as e:
        print(f"mprt {args.cmd}: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:     # outputs are written through a temporary (atomic.py): none is left half-made
        print(f"mprt {args.cmd}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:   # the reader went away (mprt scene balls | head): not an error of ours
        # what stdout still buffers goes nowhere: its flush at exit would fail on the closed pipe
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError, AttributeError):   # a stdout without a descriptor (called in-process)
            sys.stdout = open(os.devnull, "w")
        return 0
    except (MprtError, MemoryError, OSError, ValueError) as e:
        print(f"mprt {args.cmd}: error: {e}", file=sys.stderr)
        return 1
