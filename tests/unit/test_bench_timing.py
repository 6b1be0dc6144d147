"""Timing helpers of the benchmarks (workflow/lib/mshbm_workflow/benchlib.py) and the pyHarm models shared by the two
pyHarm benchmarks (workflow/lib/mshbm_workflow/pyharmlib.py), without pyHarm.

* ``interleaved_blocks``: the call order (rounds of ``block`` consecutive calls of each case, alternating),
  the warm-up, and the shape of the result; ``block_stats``: median/min over all calls and of the first
  and the other calls of each block, on given times;
* ``pyharmlib.model_input`` / ``connector``: our M, C, K, forcing and element parameters in pyHarm's input.
"""
import numpy as np
import pytest

from mshbm_workflow import benchlib as bl, pyharmlib as phl


def test_interleaved_blocks_call_order_and_shape():
    calls = []
    cases = {"a": lambda: calls.append("a"), "b": lambda: calls.append("b"), "c": lambda: calls.append("c")}
    rows = bl.interleaved_blocks(cases, rounds=2, block=3, warmup=1)
    # warm-up: one call each; then per round 3 a, 3 b, 3 c
    assert "".join(calls) == "abc" + ("aaa" + "bbb" + "ccc") * 2
    assert set(rows) == {"a", "b", "c"}
    for k in rows:
        assert len(rows[k]) == 2 and all(len(r) == 3 for r in rows[k])
        assert all(t >= 0.0 for r in rows[k] for t in r)


def test_block_stats_first_and_rest():
    rows = [[5.0, 1.0, 2.0], [7.0, 3.0, 1.5]]  # the first call of each block slower (cold)
    st = bl.block_stats(rows)
    assert st["repeats"] == 6 and st["rounds"] == 2 and st["block"] == 3
    assert st["median_s"] == pytest.approx(np.median([5, 1, 2, 7, 3, 1.5]))  # 2.5
    assert st["min_s"] == 1.0
    assert st["first_of_block"] == {"median_s": 6.0, "min_s": 5.0}
    assert st["rest_of_block"]["median_s"] == pytest.approx(1.75) and st["rest_of_block"]["min_s"] == 1.0


def test_pyharm_model_input_is_our_system():
    system = bl.impact_chain(5, gap=0.1, kc=8000.0)
    conn = phl.connector(system, "penalty")
    assert conn == {"type": "PenaltyUnilateralGap", "k": 8000.0, "g": 0.1, "connect": {"chain": [0]}, "dirs": [0]}
    inp = phl.model_input(system, 5, 512, conn, {"frf": {"study": "frf"}}, element_name="contact")
    assert list(inp) == ["system", "substructures", "connectors", "analysis"]
    assert inp["system"] == {"type": "Base", "nh": 5, "nti": 512, "adim": {"status": False, "lc": 1.0, "wc": 1.0}}
    mat = inp["substructures"]["chain"]["matrix"]
    for a in "MCK":
        assert np.array_equal(mat[a], system.dense(a))
    assert not mat["G"].any()
    force = inp["connectors"]["force"]
    assert force["connect"] == {"chain": [4]} and force["amp"] == 5.0  # 5 cos(omega t) on mass n
    assert list(inp["connectors"]) == ["force", "contact"] and inp["connectors"]["contact"] is conn
    with pytest.raises(ValueError):
        phl.connector(system, "no-such-law")
