"""The inline run page's private folder (``.brachia-view-PID-K`` in the temporary folder) under a real
``kill -9``: the folder is a locked staging folder (docs/limits.md), so a later page removes a dead
process's folder and never a live one's."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

from conftest import TRACKING

# A child that draws the page of a scenario's run over and over, printing a line per page.
DRAW_FOREVER = f"""
import sys, brachia
sc = brachia.Scenario.from_toml({str(TRACKING)!r})
plan = sc.plan()
res = sc.track(controller="pd", reference=plan)
print("ready", flush=True)
while True:
    assert res._view_html() is not None
    print("page", flush=True)
"""

# A child that draws one page and exits.
DRAW_ONCE = f"""
import brachia
sc = brachia.Scenario.from_toml({str(TRACKING)!r})
res = sc.track(controller="pd")
assert res._view_html() is not None
"""


def view_folders(tmp: Path) -> list[Path]:
    return sorted(p for p in tmp.iterdir() if p.name.startswith(".brachia-view-"))


def start(code: str, tmp: Path) -> subprocess.Popen:
    env = dict(os.environ, TMPDIR=str(tmp))
    return subprocess.Popen(
        [sys.executable, "-c", code],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def wait_for(p: subprocess.Popen, word: str, count: int = 1) -> None:
    seen = 0
    for line in p.stdout:
        if line.strip() == word:
            seen += 1
            if seen >= count:
                return
    raise AssertionError(f"the child ended before {word!r}: {p.stderr.read()}")


def test_a_killed_pages_folder_is_cleared_and_a_live_one_kept(tmp_path):
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    mine = tmp / ".brachia-view-mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("the user's, with no lock file")
    left_by_kills = 0
    # kill -9 at several points of drawing pages: each may leave its folder behind
    for delay in (0.0, 0.02, 0.08):
        p = start(DRAW_FOREVER, tmp)
        wait_for(p, "page")
        time.sleep(delay)
        p.send_signal(signal.SIGKILL)
        p.wait()
        p.stdout.close()
        p.stderr.close()
        left = [f for f in view_folders(tmp) if f != mine]
        for f in left:
            # what a killed page leaves is a staging folder with its lock file, one whose lock file
            # was still being made (alone in it), or an empty one
            inside = sorted(p.name for p in f.iterdir())
            assert (f / ".brachia-stage").is_file() or inside in ([], [".brachia-stage.new"]), f
        left_by_kills += len(left)
    # a live child draws pages while other processes draw theirs: its folder is never removed
    live = start(DRAW_FOREVER, tmp)
    wait_for(live, "ready")
    once = start(DRAW_ONCE, tmp)
    _, err = once.communicate(timeout=120)
    assert once.returncode == 0, err
    wait_for(live, "page", 2)
    live.send_signal(signal.SIGKILL)
    live.wait()
    live_err = live.stderr.read()
    live.stdout.close()
    live.stderr.close()
    assert "Traceback" not in live_err, live_err
    # the next page clears every dead process's folder, and leaves the user's folder alone
    once = start(DRAW_ONCE, tmp)
    _, err = once.communicate(timeout=120)
    assert once.returncode == 0, err
    assert view_folders(tmp) == [mine], (left_by_kills, view_folders(tmp))
    assert (mine / "notes.txt").read_text() == "the user's, with no lock file"
