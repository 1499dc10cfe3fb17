"""The corpus of hostile Python calls (``data/hostile_calls.toml``): every public entry point given
the wrong byte order, dtype, shape, a NaN, a huge value or a wrong type raises ``BrachiaError`` naming
the argument, fast, and never returns NaN. Also: an object shared by threads, and Ctrl-C
(KeyboardInterrupt) during a long plan."""

import math
import threading
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest

import brachia

from conftest import ROOT

CASES = tomllib.loads((Path(__file__).parent / "data" / "hostile_calls.toml").read_text())["case"]


@pytest.fixture(autouse=True)
def at_root(monkeypatch):
    monkeypatch.chdir(ROOT)


@pytest.mark.parametrize("case", CASES, ids=[c["what"] for c in CASES])
def test_a_hostile_call_is_refused_naming_the_argument(case, tmp_path):
    def tmp_text(text: str, name: str) -> str:
        p = tmp_path / name
        p.write_text(text)
        return str(p)

    scope = {
        "brachia": brachia,
        "np": np,
        "r": brachia.Robot.paper(),
        "q": np.array([-2.35, 0.0, -1.55, 0.0]),
        "qd": np.zeros(4),
        "tmp_text": tmp_text,
    }
    start = time.perf_counter()
    with pytest.raises(brachia.BrachiaError) as e:
        out = eval(case["call"], scope)  # noqa: S307 - the corpus is this repository's own data
        pytest.fail(f"accepted, returned {out!r}")
    took = time.perf_counter() - start
    msg = str(e.value)
    for w in case["words"]:
        assert w in msg, f"{w!r} not in {msg!r}"
    assert took < 1.0, f"the refusal took {took:.2f} s"


def test_the_corpus_covers_every_class():
    assert len(CASES) >= 35
    assert len({c["what"] for c in CASES}) == len(CASES)


def test_a_little_endian_copy_and_a_strided_view_give_the_same_numbers():
    r = brachia.Robot.paper()
    q = np.array([-2.35, 0.3, -1.55, 0.2])
    for other in (q.astype(">f8"), np.repeat(q, 2)[::2], q.astype(np.float32).astype(np.float64)):
        try:
            m = r.M(other)
        except brachia.BrachiaError:
            continue  # refusing is also correct; a wrong answer is not
        assert np.allclose(m, r.M(q), rtol=1e-6, atol=0), other.dtype


def test_one_robot_is_usable_from_many_threads():
    r = brachia.Robot.paper()
    q = np.array([-2.35, 0.3, -1.55, 0.2])
    want = r.M(q)
    errors = []

    def work():
        try:
            for _ in range(200):
                if not np.array_equal(r.M(q), want):
                    errors.append("a different answer")
        except Exception as e:  # noqa: BLE001 - any exception is a failure of the test
            errors.append(repr(e))

    threads = [threading.Thread(target=work) for _ in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert all(math.isfinite(v) for v in want.ravel())
