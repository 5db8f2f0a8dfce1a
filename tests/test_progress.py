"""No silent long work (issue 20, item 2): phase lines on stderr, one at each start and end when
not on a terminal, a bar against the estimate (or a spinner) on one.  The lines are checked, not
the timing."""
import io

from mprt import cli
from mprt.progress import Phases, clock_step, eta_text, rate_estimate


class Terminal(io.StringIO):
    def isatty(self):
        return True


def test_a_step_off_a_terminal_prints_one_line_at_its_start_and_one_at_its_end():
    out = io.StringIO()
    now = [0.0]
    with clock_step("costing 10 visits", 12.0, stream=out, clock=lambda: now[0]):
        now[0] = 11.5
    assert out.getvalue().splitlines() == ["costing 10 visits, about 12 s", "costing 10 visits: done in 11.5 s"]


def test_a_step_that_fails_says_it_stopped():
    out = io.StringIO()
    try:
        with clock_step("search", None, stream=out):
            raise KeyError("x")
    except KeyError:
        pass
    lines = out.getvalue().splitlines()
    assert lines[0] == "search" and lines[1].startswith("search: stopped in ")


def test_on_a_terminal_a_step_draws_a_bar_against_its_estimate_or_a_spinner():
    for estimate, words in ((30.0, "0 of about 30 s"), (None, "s elapsed")):
        out = Terminal()
        with clock_step("phase 1/2: replaying at level 3", estimate, stream=out):
            pass
        text = out.getvalue()
        assert "phase 1/2" in text and words in text and "replaying at level 3: done in" in text


def test_phases_are_numbered():
    out = io.StringIO()
    ph = Phases(3, stream=out)
    with ph.step("ladder", 2.0):
        pass
    ph.line("search, up to 100 designs", 40.0)
    with ph.step("references"):
        pass
    lines = out.getvalue().splitlines()
    assert lines[0] == "phase 1/3: ladder, about 2 s"
    assert lines[2] == "phase 2/3: search, up to 100 designs, about 40 s"
    assert lines[3] == "phase 3/3: references"


def test_eta_and_rate():
    assert eta_text(None) == "" and eta_text(0.2) == "under a second" and eta_text(300) == "about 5.0 min"
    assert rate_estimate(2.0, 10, 50) == 10.0 and rate_estimate(0.0, 0, 5) is None


def test_simulate_shows_the_replay_phases_with_an_estimate(monkeypatch, capsys):
    from mprt.fidelity import cli as fcli
    monkeypatch.setattr(fcli, "PHASE_VISITS", 0)          # a small trace, shown as a large one is
    assert cli.main(["simulate", "balls:1", "--res", "32x32", "--model", "3mppe", "--threads", "1"]) == 0
    err = capsys.readouterr().err
    assert "visits at level 3 on the compiled engine: estimated" in err and "M visits/s" in err
    for k, name in ((1, "costing and loading"), (2, "replaying at level 3")):
        assert f"phase {k}/2: {name}" in err
    assert err.count(": done in ") == 2


def test_simulate_of_a_small_trace_prints_no_phases(capsys):
    assert cli.main(["simulate", "tetra:1", "--res", "16x16", "--model", "M", "--threads", "1"]) == 0
    assert "phase" not in capsys.readouterr().err


# -- explore: each phase numbered, with an estimate from the phases before it ----------------------
def _explore(argv, capsys):
    from pathlib import Path
    small = Path(__file__).parent / "data" / "explore" / "small_space.toml"
    assert cli.main(["explore", "tetra:1", "--space", str(small), "--max-evals", "20", "--workers", "0",
                     "--threads", "1"] + argv) == 0
    return capsys.readouterr().err


def test_explore_announces_every_phase_numbered(capsys):
    err = _explore(["--res", "64x64", "--fraction", "2"], capsys)
    names = ["ladder", "subdivisions", "search", "full resolution"]
    for k, name in enumerate(names, 1):
        assert f"phase {k}/4: {name}" in err, (name, err)
    for name in names[1:]:              # each after the first estimated from what ran before it
        line = err.split(f": {name}")[1].splitlines()[0]
        assert "about" in line or "under a second" in line, line
    assert err.count(": done in ") == 3            # the search ends with its own summary line
    assert "search  done in" in err


def test_explore_at_a_fixed_level_has_no_ladder_phase(capsys):
    err = _explore(["--res", "16x16", "--level", "1"], capsys)
    assert "phase 1/3: subdivisions" in err and "phase 2/3: search" in err and "phase 3/3: full resolution" in err
    assert "ladder" not in err


def test_explore_on_a_scheduler_sends_its_evaluations_there(monkeypatch, capsys):
    """--scheduler: every evaluation is a task of the Dask client's (here a stand-in that runs them
    in this process and counts them)."""
    import contextlib
    from mprt.explore import distributed
    sent = []

    class Client:
        def submit(self, fn, *args, pure=True):
            sent.append(args)
            return fn(*args)

        def gather(self, futures):
            return list(futures)

    @contextlib.contextmanager
    def client(address=None, workers=None):
        assert address == "tcp://nowhere:1"
        yield Client()
    monkeypatch.setattr(distributed, "client", client)
    _explore(["--res", "16x16", "--level", "1", "--scheduler", "tcp://nowhere:1"], capsys)
    assert "evaluations on the Dask scheduler tcp://nowhere:1" in capsys.readouterr().out or sent
    assert len(sent) > 10


def test_explore_progress_lines_appear_as_the_search_runs(tmp_path):
    """Under a pipe, the search's progress lines arrive while it runs, not in one burst at its end:
    their arrival times spread over most of the search phase."""
    import subprocess
    import sys
    import time as _t
    from pathlib import Path
    small = Path(__file__).parent / "data" / "explore" / "small_space.toml"
    cmd = [sys.executable, "-m", "mprt", "explore", "tetra:1", "balls:1", "--res", "64x64", "--space", str(small),
           "--level", "3", "--max-evals", "150", "--workers", "0", "--no-bound"]
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, bufsize=1)
    seen = []
    for line in p.stderr:
        seen.append((_t.perf_counter(), line))
    assert p.wait() == 0
    start = next(t for t, ln in seen if ": search" in ln and ln.startswith("phase"))
    end = next(t for t, ln in seen if ln.startswith("search  ") and " machines (" in ln)    # the search's summary
    ticks = [t for t, ln in seen if " machines" in ln and ln.startswith("  ")]
    assert len(ticks) >= 3
    assert end - start > 0.2 and ticks[-1] - ticks[0] >= 0.5 * (end - start) - 0.05


def test_the_search_counts_its_evaluations_against_the_global_phase_with_the_time_left():
    from types import SimpleNamespace
    from mprt.explore.cli import _progress_printer
    out = Terminal()
    show = _progress_printer(total=100, stream=out)
    best = SimpleNamespace(cycles=1000.0, cost=50.0)
    for n in (1, 40, 120):
        show(SimpleNamespace(memo=range(n), best=lambda: best))
    show.end()
    text = out.getvalue()
    assert "40 machines of up to 100" in text and "left" in text
    assert "120 machines, best 50 kGE" in text and "polishing" in text
