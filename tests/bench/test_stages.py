"""Per-stage timing with a budget per stage (nothing timed is asserted, and no stage that
must finish runs under a wall-clock budget)."""

import math

from mbgen.bench.stages import format_stages, stage_times


def test_every_stage_of_a_small_scene_finishes():
    messages = []
    rows = stage_times("disc_pendulum", outputs=("rhs", "jacobian"), budget_s=math.inf,
                       progress=messages.append)
    assert [r.stage for r in rows] == ["derive", "bake", "cse[rhs]", "cse[jacobian]", "cse[all]",
                                       "render", "compile"]
    assert all(r.status == "ok" and r.seconds > 0 and r.max_rss_gb > 0 for r in rows)
    cse_all = rows[4]
    assert 0 < cse_all.ops_after < cse_all.ops_before
    assert messages[0] == "disc_pendulum: derive"
    text = format_stages("disc_pendulum", rows)
    assert text.splitlines()[2].split()[0] == "derive" and "total" in text.splitlines()[-1]


def test_a_stage_over_its_budget_is_stopped_and_reported():
    rows = stage_times("bicycle", budget_s=0.5)
    *done, stopped = rows
    assert stopped.seconds is None and stopped.status == "over the 0.5 s budget, stopped"
    assert all(r.status == "ok" and r.seconds > 0 for r in done)
    assert stopped.stage != "compile"
