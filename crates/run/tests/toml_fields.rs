//! A value of the wrong type in a scenario, a traverse scenario or a parameters file is refused naming
//! the dotted field as written (`tracking.replan.threshold_m`, `links[2].mass`) beside the parser's
//! line, column and text.

use brachia::model::RobotParams;
use brachia_run::ladder::LadderScenario;
use brachia_run::scenario::Scenario;
use std::path::Path;

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

fn scenario_text(name: &str) -> String {
    std::fs::read_to_string(root().join("scenarios").join(name)).unwrap()
}

fn refused(text: &str) -> String {
    Scenario::from_toml_str(text, "x.toml")
        .unwrap_err()
        .to_string()
}

#[test]
fn a_scenario_type_error_names_the_dotted_field() {
    let base = scenario_text("tracking.toml");
    let cases = [
        (
            "\n[tracking]\nreplan = { threshold_m = \"1 cm\" }\n",
            "tracking.replan.threshold_m",
            "\"1 cm\"",
        ),
        (
            "\n[tracking.replan]\nthreshold_m = true\n",
            "tracking.replan.threshold_m",
            "true",
        ),
        (
            "\n[tracking.mpc]\nhorizon = 2.5\n",
            "tracking.mpc.horizon",
            "2.5",
        ),
    ];
    for (extra, field, text) in cases {
        let e = refused(&format!("{base}{extra}"));
        assert!(
            e.starts_with(&format!("x.toml: field `{field}`: ")),
            "{field}: {e}"
        );
        assert!(e.contains("line ") && e.contains(text), "{field}: {e}");
    }
    // in a section written earlier, and an array entry
    let e = refused(&base.replace("knot_dt = 0.03", "knot_dt = \"fine\""));
    assert!(e.contains("field `planner.knot_dt`"), "{e}");
    let e = refused(&base.replace("q0 = [-2.35, 0.0,", "q0 = [-2.35, \"up\","));
    assert!(e.contains("field `task.q0[1]`"), "{e}");
    // an unknown field is named where it stands
    let e = refused(&format!("{base}\n[tracking.mpc]\nhorizont = 10\n"));
    assert!(e.contains("field `tracking.mpc.horizont`"), "{e}");
}

#[test]
fn traverse_scenarios_and_parameters_files_name_it_too() {
    let base = scenario_text("ladder-even.toml");
    let text = base.replacen("capture_radius = 0.02", "capture_radius = \"2 cm\"", 1);
    assert_ne!(text, base);
    let dir = root().join("scenarios");
    let e = LadderScenario::load_str(&text, &dir.join("x.toml"), &dir)
        .unwrap_err()
        .to_string();
    assert!(e.contains("field `ladder.capture_radius`"), "{e}");

    let params = std::fs::read_to_string(root().join("params/paper.toml")).unwrap();
    let mut seen = 0;
    let bad: String = params
        .lines()
        .map(|l| {
            if l.starts_with("mass =") {
                seen += 1;
                if seen == 3 {
                    return "mass = \"heavy\"".to_string();
                }
            }
            l.to_string()
        })
        .collect::<Vec<_>>()
        .join("\n");
    let e = RobotParams::from_toml_str(&bad, "p.toml")
        .unwrap_err()
        .to_string();
    assert!(e.starts_with("p.toml: field `links[2].mass`: "), "{e}");
}
