"""The estimator's hand-over settings and the re-planning settings are as strict in Python as in a
scenario file (the CLI's hostile corpus, crates/cli/tests/hostile/): zero, NaN, a negative, an
infinite or a huge value, a wrong type and an inconsistent pair each raise ``BrachiaError`` naming the
field, whether given as a keyword argument, in the settings dict or in a scenario's text."""

import math

import pytest

import brachia

from conftest import ROOT, TRACKING

TASK = {"q0": [-2.35, 0.0, -1.55, 0.0], "target": [0.8, 0.0]}

# (field, value): the estimator's hand-over tests
ESTIMATE_CASES = [
    ("use_max_rel_std", 0.0),
    ("use_max_rel_std", -0.02),
    ("use_max_rel_std", math.nan),
    ("use_max_rel_std", math.inf),
    ("use_max_rel_std", "0.02"),
    ("use_max_nis_ratio", 0.0),
    ("use_max_nis_ratio", -1.1),
    ("use_max_nis_ratio", math.nan),
    ("use_max_nis_ratio", math.inf),
    ("use_max_nis_ratio", None),
    ("use_min_sigma", -1.0),
    ("use_min_sigma", math.nan),
    ("use_min_sigma", math.inf),
    ("use_min_sigma", -math.inf),
    ("use_min_sigma", [3.0]),
    ("use_min_rel_change", -0.03),
    ("use_min_rel_change", math.nan),
    ("use_min_rel_change", math.inf),
    ("use_min_rel_change", 1e400),
    ("use_min_rel_change", {"value": 0.03}),
]

# (settings, field): the re-planning settings
REPLAN_CASES = [
    ({"average_steps": 0}, "average_steps"),
    ({"average_steps": -1}, "average_steps"),
    ({"average_steps": 1_000_000}, "average_steps"),
    ({"average_steps": 2**64}, "average_steps"),
    ({"average_steps": 10**30}, "average_steps"),
    ({"average_steps": 2.5}, "average_steps"),
    ({"average_steps": math.nan}, "average_steps"),
    ({"average_steps": math.inf}, "average_steps"),
    ({"average_steps": "20"}, "average_steps"),
    ({"compare_at_switch": True, "compare_before_adopting": False}, "compare_at_switch"),
    ({"compare_at_switch": "yes"}, "compare_at_switch"),
    ({"compare_at_switch": 1}, "compare_at_switch"),
    ({"compare_at_switch": None}, "compare_at_switch"),
]


def case_id(field, value):
    return f"{field}={value!r}"


@pytest.fixture(scope="module")
def mpc(robot, tracking_plan):
    return brachia.Mpc(robot, tracking_plan)


@pytest.mark.parametrize("field,value", ESTIMATE_CASES, ids=[case_id(*c) for c in ESTIMATE_CASES])
@pytest.mark.parametrize("how", ["keyword", "dict"])
def test_estimate_settings_refuse_a_bad_value_naming_the_field(mpc, field, value, how):
    with pytest.raises(brachia.BrachiaError) as e:
        if how == "keyword":
            brachia.Adaptive(mpc, **{field: value})
        else:
            brachia.Adaptive(mpc, {field: value})
    assert field in str(e.value), str(e.value)


@pytest.mark.parametrize("settings,field", REPLAN_CASES, ids=[case_id(f, s) for s, f in REPLAN_CASES])
@pytest.mark.parametrize("how", ["keyword", "dict"])
def test_replan_settings_refuse_a_bad_value_naming_the_field(mpc, settings, field, how):
    with pytest.raises(brachia.BrachiaError) as e:
        if how == "keyword":
            brachia.Replanning(mpc, TASK, **settings)
        else:
            brachia.Replanning(mpc, TASK, None, settings)
    assert field in str(e.value), str(e.value)


def test_the_edges_the_scenario_file_accepts_are_accepted(mpc):
    # zero turns the significance tests off; the largest averaging and the compare pair are valid
    a = brachia.Adaptive(mpc, use_min_sigma=0.0, use_min_rel_change=0.0, use_max_rel_std=1e3)
    assert a.settings["use_min_sigma"] == 0.0 and a.settings["use_max_rel_std"] == 1e3
    r = brachia.Replanning(mpc, TASK, average_steps=1000, compare_at_switch=True, compare_before_adopting=True)
    assert r.settings["average_steps"] == 1000 and r.settings["compare_at_switch"] is True


# the CLI corpus's scenario lines (sweep.txt, surfaces.txt), read by Scenario.from_toml_str
TOML_CASES = [
    ("estimate_params = { use_max_rel_std = 0.0 }", "use_max_rel_std"),
    ("estimate_params = { use_max_nis_ratio = nan }", "use_max_nis_ratio"),
    ("estimate_params = { use_min_sigma = -1.0 }", "use_min_sigma"),
    ("estimate_params = { use_min_rel_change = inf }", "use_min_rel_change"),
    ("replan = { average_steps = 0 }", "average_steps"),
    ("replan = { average_steps = 1000000 }", "average_steps"),
    ("replan = { compare_at_switch = true, compare_before_adopting = false }", "compare_at_switch"),
]


@pytest.mark.parametrize("line,field", TOML_CASES, ids=[f for _, f in TOML_CASES])
def test_a_scenario_text_refuses_what_the_cli_refuses(line, field):
    text = TRACKING.read_text() + f'\n[tracking]\ncontroller = "mpc"\n{line}\n'
    with pytest.raises(brachia.BrachiaError) as e:
        brachia.Scenario.from_toml_str(text, base_dir=ROOT / "scenarios", source_name="strict.toml")
    assert field in str(e.value) and "strict.toml" in str(e.value), str(e.value)
