"""The scaling benchmark runs end to end and reports sane numbers (no timing assertions)."""

import os

import pytest

from mbgen.bench.scaling import ScalingRow, format_scaling, scaling


@pytest.fixture(scope="module")
def rows():
    messages = []
    cache_before = os.environ.get("MBGEN_CACHE_DIR")
    result = scaling(ns=(2,), repeats=2, progress=messages.append)
    assert os.environ.get("MBGEN_CACHE_DIR") == cache_before  # temporary cache restored
    assert messages[:2] == ["warm-up (n=1, not reported)", "n=2: mbgen derive"]
    assert "n=2: sympy CSE" in messages
    return result


def test_both_sides_present_and_positive(rows):
    row, = rows
    assert row.n == 2
    for value in (row.derive_s, row.cse_s, row.render_s, row.compile_s, row.rhs_s,
                  row.sympy_derive_s, row.sympy_cse_s, row.sympy_rhs_s):
        assert value is not None and value > 0
    assert 0 < row.ops_after < row.ops_before
    assert 0 < row.sympy_ops_after < row.sympy_ops_before
    assert row.rhs_max_abs_diff < 1e-9  # both sides timed the same right-hand side


def test_ratios_are_sympy_over_mbgen(rows):
    row, = rows
    assert row.derive_ratio == pytest.approx(row.sympy_derive_s / row.derive_s)
    assert row.cse_ratio == pytest.approx(row.sympy_cse_s / row.cse_s)
    assert row.total_ratio == pytest.approx((row.sympy_derive_s + row.sympy_cse_s)
                                            / (row.derive_s + row.cse_s))
    assert row.rhs_ratio == pytest.approx(row.sympy_rhs_s / row.rhs_s)


def test_table(rows):
    skipped = ScalingRow(n=64, derive_s=1.0, cse_s=0.5, render_s=0.1, compile_s=2.0,
                         rhs_s=1e-5, ops_before=100, ops_after=10)
    assert skipped.derive_ratio is skipped.total_ratio is skipped.rhs_ratio is None
    lines = format_scaling([*rows, skipped]).splitlines()
    header, rule, row2, row64 = lines[:4]
    assert header.split()[0] == "n" and set(rule) == {"-"}
    assert len(row2) <= len(header) and len(row64) <= len(header)
    cells = row2.split()
    assert cells[0] == "2" and "-" not in cells
    assert float(cells[3]) == pytest.approx(rows[0].derive_ratio, abs=0.05)
    assert row64.split()[0] == "64" and row64.split().count("-") == 8
    assert lines[-1] == "BLAS threads pinned to 1 (threadpoolctl)."


def test_child_process_entry_points_exist():
    """Every ``python -m mbgen.bench.X`` a benchmark starts names a module that runs as one."""
    import re
    from pathlib import Path

    import mbgen.bench

    folder = Path(mbgen.bench.__file__).parent
    started = {name for path in folder.glob("*.py")
               for name in re.findall(r'"-m",\s*"mbgen\.bench\.(\w+)"', path.read_text())}
    assert started >= {"arm", "constraints", "stages"}
    for name in started:
        text = (folder / f"{name}.py").read_text()
        assert 'if __name__ == "__main__":' in text, name
