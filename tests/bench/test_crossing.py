"""``python -m mbgen.bench.crossing``: a tiny run fills every column (nothing timed is asserted)."""

from mbgen.bench import crossing


def test_a_small_run_fills_its_columns(capsys):
    row = crossing.measure(2, rounds=1, calls=50, c_loop=False)
    for key in ("before_p_ns", "after_p_ns", "before_ns", "after_ns"):
        assert getattr(row, key) > 0, key
    assert crossing.main(["--ns", "2", "--rounds", "1", "--calls", "20", "--no-c-loop"]) == 0
    out = capsys.readouterr().out
    assert "entry (t,x,p)" in out and "pin.aba" in out
