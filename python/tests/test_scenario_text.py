"""Scenarios read from a string: the same scenario as the file, relative params paths resolved against
base_dir, errors naming source_name."""

import pytest

import brachia

from conftest import ROOT, TRACKING


def test_a_string_is_the_file(scenario):
    text = TRACKING.read_text()
    s = brachia.Scenario.from_toml_str(text, base_dir=TRACKING.parent, source_name="tracking.toml")
    assert s.name == "tracking"
    assert s.task == scenario.task and s.plan_settings == scenario.plan_settings
    assert s.tracking == scenario.tracking and s.disturbances == scenario.disturbances
    assert s.robot.params == scenario.robot.params
    # without a source name it is "<string>"
    assert brachia.Scenario.from_toml_str(text, base_dir=TRACKING.parent).name == "<string>"


def test_params_are_relative_to_base_dir(tmp_path, monkeypatch):
    text = TRACKING.read_text()
    monkeypatch.chdir(tmp_path)
    # "../params/paper.toml" from the working directory does not exist
    with pytest.raises(brachia.BrachiaError, match="paper.toml"):
        brachia.Scenario.from_toml_str(text, source_name="mine.toml")
    s = brachia.Scenario.from_toml_str(text.replace("../params", "params"), base_dir=ROOT)
    assert s.robot.n_links == 4


def test_errors_name_the_source_and_the_field():
    text = TRACKING.read_text().replace("knot_dt = 0.03", "knot_dt = -0.03")
    with pytest.raises(brachia.BrachiaError, match=r"mine\.toml.*planner\.knot_dt"):
        brachia.Scenario.from_toml_str(text, base_dir=TRACKING.parent, source_name="mine.toml")
    with pytest.raises(brachia.BrachiaError, match=r"mine\.toml.*bogus"):
        brachia.Scenario.from_toml_str(
            TRACKING.read_text() + "\n[tracking]\nbogus = 1\n", base_dir=TRACKING.parent, source_name="mine.toml"
        )
    with pytest.raises(brachia.BrachiaError, match=r"mine\.toml"):
        brachia.Scenario.from_toml_str("params = [", source_name="mine.toml")
    with pytest.raises(brachia.BrachiaError, match="at most"):
        brachia.Scenario.from_toml_str("#" * (1 << 21))
