"""A campaign accounts for every run, Ctrl-C stops it, and every public
object and exception pickles (issue 36)."""

from __future__ import annotations

import pickle
import signal
import subprocess
import sys
import textwrap
import time
from concurrent.futures import Executor, Future, ProcessPoolExecutor

import pytest

import bellyflop

RUNS, SEED = 6, 5


@pytest.fixture(scope="module")
def reference():
    return bellyflop.montecarlo(RUNS, seed=SEED, threads=2)


def deterministic(c: bellyflop.Campaign) -> list:
    from test_campaign import deterministic_rows

    return deterministic_rows(c.runs_csv())


class Unreliable(Executor):
    """Runs each task at once in this process and hands back what `alter`
    makes of its rows (a lost future when it raises)."""

    def __init__(self, alter):
        self.alter = alter
        self.calls = []

    def submit(self, fn, *args, **kwargs):
        self.calls.append(args)
        f: Future = Future()
        try:
            attempt = args[5] if len(args) > 5 else 0
            f.set_result(self.alter(list(fn(*args, **kwargs)), attempt))
        except Exception as e:  # noqa: BLE001 - the future carries it
            f.set_exception(e)
        return f


def test_lost_rows_are_resubmitted(reference):
    # Runs 1 and 4 are lost on the first attempt, then come back.
    def drop_first(rows, attempt):
        return [r for r in rows if attempt > 0 or r[0] not in (1, 4)]

    ex = Unreliable(drop_first)
    c = bellyflop.montecarlo(RUNS, seed=SEED, executor=ex, chunk=2)
    assert len(c) == RUNS and c.summary["runs"] == RUNS
    assert deterministic(c) == deterministic(reference)
    assert len(ex.calls) == 3 + 2  # three chunks, then runs 1 and 4 again


def test_a_lost_future_is_resubmitted(reference):
    def fail_first(rows, attempt):
        if attempt == 0 and rows[0][0] == 2:
            raise ConnectionError("worker lost")
        return rows

    c = bellyflop.montecarlo(RUNS, seed=SEED, executor=Unreliable(fail_first), chunk=2)
    assert deterministic(c) == deterministic(reference)


def test_runs_that_never_come_back_are_an_error_that_keeps_the_rest():
    ex = Unreliable(lambda rows, attempt: [r for r in rows if r[0] not in (1, 4)])
    with pytest.raises(bellyflop.CampaignError, match=r"2 of the campaign's 6 runs did not come back: runs 1, 4") as e:
        bellyflop.montecarlo(RUNS, seed=SEED, executor=ex, chunk=2, retries=2)
    assert e.value.missing == [1, 4]
    assert list(e.value.campaign["run"]) == [0, 2, 3, 5]
    assert e.value.campaign.summary["runs"] == 4
    assert len(ex.calls) == 3 + 2 * 2  # two retries of runs 1 and 4
    again = pickle.loads(pickle.dumps(e.value))
    assert type(again) is bellyflop.CampaignError and again.missing == [1, 4]
    assert str(again) == str(e.value) and len(again.campaign) == 4


def test_an_equal_duplicate_is_dropped(reference):
    c = bellyflop.montecarlo(RUNS, seed=SEED, executor=Unreliable(lambda rows, a: rows + rows), chunk=2)
    assert len(c) == RUNS and c.summary["runs"] == RUNS
    assert deterministic(c) == deterministic(reference)


def test_a_differing_duplicate_is_an_error():
    def twice_differing(rows, attempt):
        other = list(rows[0])
        other[3] = other[3] + 1.0  # x_error_m
        return rows + [tuple(other)]

    with pytest.raises(bellyflop.CampaignError, match=r"run 0 came back twice with different results: x_error_m"):
        bellyflop.montecarlo(RUNS, seed=SEED, executor=Unreliable(twice_differing), chunk=2)


# --- Ctrl-C

SIGINT_CHILD = textwrap.dedent(
    """
    import signal, sys, time
    from concurrent.futures import ProcessPoolExecutor
    import bellyflop
    # A test suite started in the background by a non-interactive shell
    # inherits SIGINT ignored, and Python then keeps it ignored: the
    # child would never see the Ctrl-C this test sends.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    mode = sys.argv[1]
    print("ready", flush=True)
    def campaign(**kw):
        try:
            bellyflop.montecarlo(400, seed=1, **kw)
            print("finished", flush=True)
        except KeyboardInterrupt:
            # Where montecarlo's caller sees it (before the pool's own
            # shutdown waits for the chunks in flight).
            print("interrupted", time.monotonic(), flush=True)
    if mode == "threads":
        campaign(threads=2)
    else:
        with ProcessPoolExecutor(2) as ex:
            campaign(executor=ex, chunk=2)
    """
)


@pytest.mark.parametrize("mode", ["threads", "pool"])
def test_ctrl_c_raises_keyboard_interrupt_within_a_second(mode):
    p = subprocess.Popen(
        [sys.executable, "-c", SIGINT_CHILD, mode], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    assert p.stdout.readline().strip() == "ready"
    time.sleep(2.0)  # in the campaign
    sent = time.monotonic()
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    words = out.split()
    assert words and words[0] == "interrupted", (out, err[-2000:])
    latency = float(words[1]) - sent
    print(f"SIGINT -> KeyboardInterrupt ({mode}): {latency:.3f} s")
    assert latency <= 1.0, latency


# --- pickling


def _round_trip(x):
    y = pickle.loads(pickle.dumps(x))
    assert type(y) is type(x)
    assert type(x).__module__ == "bellyflop", type(x)
    return y


def test_everything_public_pickles(reference):
    s = bellyflop.Scenario.paper()
    assert _round_trip(s) == s
    c = bellyflop.SimConfig()
    assert _round_trip(c) == c
    sec = s.initial
    again = _round_trip(sec)
    assert again == sec and again.to_dict() == sec.to_dict() and again.mass_kg == sec.mass_kg
    assert _round_trip(s.solver.direct) == s.solver.direct
    sol = bellyflop.solve(fast=True)
    assert _round_trip(sol) == sol
    f = bellyflop.sim(seed=1, run=0)
    assert _round_trip(f) == f
    camp = _round_trip(reference)
    assert camp == reference and camp.runs_csv() == reference.runs_csv()
    assert camp.summary == reference.summary
    table = reference._table
    assert _round_trip(table) == table
    for cls in (bellyflop.InputError, bellyflop.InternalError):
        e = cls("nodes = -1 is out of range: allowed 4 to 200")
        back = _round_trip(e)
        assert str(back) == str(e) and back.args == e.args
    e = bellyflop.CampaignError("1 of 2 runs", missing=[1], campaign=None)
    assert _round_trip(e).missing == [1]
    # The exceptions a call raises pickle too.
    with pytest.raises(bellyflop.InputError) as raised:
        bellyflop.solve(nodes=2)
    assert str(_round_trip(raised.value)) == str(raised.value)
