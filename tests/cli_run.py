"""The mprt command run in this process, as a test reads it: (exit status, stdout, stderr)."""
from mprt import cli


def cli_main(capsys, *args):
    """``mprt ARGS`` through ``cli.main`` (a parser's SystemExit read as its status)."""
    try:
        code = cli.main([str(a) for a in args])
    except SystemExit as e:
        code = e.code
    out = capsys.readouterr()
    return code, out.out, out.err
