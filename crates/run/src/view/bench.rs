//! The page of a benchmark folder (`brachia benchmark`): its scorecard as a table and one success
//! curve per disturbance sweep (success against level, one line per controller), drawn as inline SVG
//! from `scorecard.json` and `runs.csv`, and the Monte Carlo families' success rates with their run
//! counts (a table and a bar chart). Hovering a point or a bar names the controller, the level or the
//! family and the outcome; the page follows the light/dark theme like every run page.

use super::data::html_escape;
use crate::read::{need, read_csv_text, read_json};
use crate::schema::JsonKind;
use brachia::Error;
use std::fmt::Write as _;
use std::path::Path;

mod card;
mod families;

use card::{ControllerCard, Scorecard, SweepDef};

const TEMPLATE: &str = include_str!("../../assets/view/bench.html");
const STYLE: &str = include_str!("../../assets/view/bench.css");

const BENCH_FOLDER: &str =
    "a benchmark folder written by `brachia benchmark` (scorecard.json, runs.csv)";

/// One run of `runs.csv`, as the curves use it.
struct Run {
    controller: String,
    disturbance: String,
    level: f64,
    success: bool,
    final_error_m: f64,
}

/// `runs.csv` after its schema line: the columns the curves use, checked.
fn read_runs(file: &str, text: &str) -> Result<Vec<Run>, Error> {
    let text = crate::read::strip_bom(text);
    let mut lines = text.lines();
    let head: Vec<&str> = lines.next().unwrap_or("").trim().split(',').collect();
    let want = [
        "controller",
        "disturbance",
        "level",
        "seed",
        "success",
        "final_error_m",
    ];
    if head.len() < want.len() || head[..want.len()] != want {
        return Err(Error::invalid(
            file,
            "header",
            head.join(","),
            format!("expected {},...", want.join(",")),
        ));
    }
    let mut out = Vec::new();
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let c: Vec<&str> = line.split(',').map(str::trim).collect();
        let at = |k: usize| format!("line {}, {}", i + 3, want[k]);
        if c.len() != head.len() {
            return Err(Error::invalid(
                file,
                format!("line {}", i + 3),
                line.chars().take(160).collect::<String>(),
                format!("expected {} columns", head.len()),
            ));
        }
        let num = |k: usize| {
            c[k].parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| Error::invalid(file, at(k), c[k], "must be a finite number"))
        };
        let success = match c[4] {
            "1" => true,
            "0" => false,
            v => return Err(Error::invalid(file, at(4), v, "0 or 1")),
        };
        out.push(Run {
            controller: c[0].to_string(),
            disturbance: c[1].to_string(),
            level: num(2)?,
            success,
            final_error_m: num(5)?,
        });
    }
    Ok(out)
}

/// Numbers as the table shows them.
fn f(v: f64, digits: usize) -> String {
    format!("{v:.digits$}")
}

/// One success curve as an inline SVG: success (0 or 100 %) against level, a line per controller.
fn curve(sweep: &SweepDef, cards: &[ControllerCard], runs: &[Run]) -> String {
    let (w, h, l, rgt, top, bot) = (420.0, 200.0, 44.0, 10.0, 10.0, 34.0);
    let lv = &sweep.levels;
    let (x0, x1) = (
        lv.first().copied().unwrap_or(0.0),
        lv.last().copied().unwrap_or(1.0),
    );
    let span = if x1 > x0 { x1 - x0 } else { 1.0 };
    let sx = |x: f64| l + (w - l - rgt) * (x - x0) / span;
    let sy = |y: f64| top + (h - top - bot) * (100.0 - y) / 100.0;
    let mut s = format!(
        "<figure class=\"curve\" data-sweep=\"{name}\"><figcaption>success against {name}</figcaption>\
         <svg viewBox=\"0 0 {w} {h}\" role=\"img\" aria-label=\"success against {name}, one line \
         per controller\">",
        name = html_escape(&sweep.name)
    );
    for y in [0.0, 50.0, 100.0] {
        let _ = write!(
            s,
            "<line class=\"grid\" x1=\"{l}\" x2=\"{}\" y1=\"{y1}\" y2=\"{y1}\"/>\
             <text class=\"tick\" x=\"{}\" y=\"{}\" text-anchor=\"end\">{y} %</text>",
            w - rgt,
            l - 4.0,
            sy(y) + 4.0,
            y1 = sy(y)
        );
    }
    let _ = write!(
        s,
        "<text class=\"tick\" x=\"{l}\" y=\"{}\">{}</text><text class=\"tick\" x=\"{}\" y=\"{}\" \
         text-anchor=\"end\">{}</text><text class=\"tick\" x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>",
        h - bot + 14.0,
        x0,
        w - rgt,
        h - bot + 14.0,
        x1,
        (l + w - rgt) / 2.0,
        h - 4.0,
        html_escape(&sweep.level)
    );
    for (ci, c) in cards.iter().enumerate() {
        let pts: Vec<(f64, Option<&Run>)> = lv
            .iter()
            .map(|&x| {
                let run = runs.iter().find(|r| {
                    r.controller == c.controller && r.disturbance == sweep.name && r.level == x
                });
                (x, run)
            })
            .collect();
        // controllers drawn apart by a pixel or two so equal curves stay visible
        let dy = ci as f64 * 2.0 - cards.len() as f64;
        let path: Vec<String> = pts
            .iter()
            .filter_map(|(x, run)| {
                run.map(|r| {
                    let y = if r.success { 100.0 } else { 0.0 };
                    format!("{:.1},{:.1}", sx(*x), sy(y) + dy)
                })
            })
            .collect();
        let _ = write!(
            s,
            "<polyline class=\"s{}\" fill=\"none\" points=\"{}\"/>",
            ci % 8,
            path.join(" ")
        );
        for (x, run) in &pts {
            if let Some(r) = run {
                let y = if r.success { 100.0 } else { 0.0 };
                let _ = write!(
                    s,
                    "<circle class=\"s{} pt\" cx=\"{:.1}\" cy=\"{:.1}\" r=\"3.5\"><title>{}: {} = {} ({}): \
                     {}, final error {:.2e} m</title></circle>",
                    ci % 8,
                    sx(*x),
                    sy(y) + dy,
                    html_escape(&c.controller),
                    html_escape(&sweep.name),
                    x,
                    html_escape(&sweep.level),
                    if r.success { "success" } else { "failure" },
                    r.final_error_m
                );
            }
        }
    }
    s.push_str("</svg></figure>");
    s
}

/// The page of the benchmark folder `dir`.
pub fn benchmark_folder_html(dir: &Path) -> Result<String, Error> {
    let sfile = need(dir, "scorecard.json", BENCH_FOLDER)?;
    let rfile = need(dir, "runs.csv", BENCH_FOLDER)?;
    let card: Scorecard = read_json(&sfile, JsonKind::Scorecard)?;
    let runs = read_runs(
        &rfile.display().to_string(),
        &read_csv_text(&rfile, "runs")?,
    )?;
    Ok(benchmark_html(&card, &runs))
}

fn benchmark_html(card: &Scorecard, runs: &[Run]) -> String {
    let mut table = String::from(
        "<table><thead><tr><th>controller</th><th>robustness score</th><th>success % (all runs)</th>\
         <th>runs</th><th>energy (J)</th><th>peak torque (N m)</th><th>smoothness (N m)</th>\
         <th>final error (m)</th></tr></thead><tbody>",
    );
    for c in &card.controllers {
        let o = &c.overall;
        let _ = write!(
            table,
            "<tr><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{}</td><td>{:.2e}</td></tr>",
            html_escape(&c.controller),
            f(c.robustness_score, 3),
            f(o.success_pct, 1),
            o.runs,
            f(o.energy_j, 3),
            f(o.peak_torque_nm, 2),
            f(o.smoothness_nm, 4),
            o.final_error_m
        );
    }
    table.push_str("</tbody></table>");
    let mut per = String::from("<table><thead><tr><th>disturbance</th>");
    for c in &card.controllers {
        let _ = write!(per, "<th>{}</th>", html_escape(&c.controller));
    }
    per.push_str("</tr></thead><tbody>");
    let mut names: Vec<&str> = card.sweeps.iter().map(|s| s.name.as_str()).collect();
    for c in &card.controllers {
        for k in c.per_disturbance.keys() {
            if !names.contains(&k.as_str()) {
                names.push(k);
            }
        }
    }
    for name in names {
        let _ = write!(per, "<tr><td>{}</td>", html_escape(name));
        for c in &card.controllers {
            match c.per_disturbance.get(name) {
                Some(s) => {
                    let _ = write!(per, "<td>{} %</td>", f(s.success_pct, 1));
                }
                None => per.push_str("<td>-</td>"),
            }
        }
        per.push_str("</tr>");
    }
    per.push_str("</tbody></table>");
    let mut legend = String::new();
    for (ci, c) in card.controllers.iter().enumerate() {
        let _ = write!(
            legend,
            "<li><span class=\"sw\" style=\"background: var(--s{})\"></span>{}</li>",
            ci % 8,
            html_escape(&c.controller)
        );
    }
    let curves: String = card
        .sweeps
        .iter()
        .map(|s| curve(s, &card.controllers, runs))
        .collect();
    let title = format!("{}: robustness benchmark", card.scenario);
    let subtitle = match card.capture_speed_m_s {
        Some(v) => format!(
            "{} runs; success: the hand captures the bar (within {} m of it, no faster than {} m/s) \
             at any time of the run",
            runs.len(),
            card.success_radius_m,
            v
        ),
        None => format!(
            "{} runs; success: the final hand within {} m of the bar",
            runs.len(),
            card.success_radius_m
        ),
    };
    let body = TEMPLATE
        .replace("{{HEADER}}", &super::header(&title, &subtitle))
        .replace("{{SCORECARD}}", &table)
        .replace("{{PER_DISTURBANCE}}", &per)
        .replace("{{FAMILIES}}", &families::section(card, &legend))
        .replace("{{LEGEND}}", &legend)
        .replace("{{CURVES}}", &curves);
    super::page(&title, STYLE, &body)
}

#[cfg(test)]
mod tests {
    use super::card::Score;
    use super::*;
    use std::collections::BTreeMap;

    #[test]
    fn runs_csv_is_checked_and_curves_follow_the_runs() {
        let text = "controller,disturbance,level,seed,success,final_error_m,energy_j\n\
                    mpc,push,0,1,1,0.001,1\nmpc,push,1,2,0,0.3,1\n";
        let runs = read_runs("runs.csv", text).unwrap();
        assert_eq!(runs.len(), 2);
        let sweep = SweepDef {
            name: "push".into(),
            level: "N s".into(),
            levels: vec![0.0, 1.0],
        };
        let score = || Score {
            runs: 2,
            success_pct: 50.0,
            energy_j: 1.0,
            peak_torque_nm: 1.0,
            smoothness_nm: 0.1,
            final_error_m: 0.1,
        };
        let cards = vec![ControllerCard {
            controller: "mpc".into(),
            robustness_score: 0.5,
            overall: score(),
            per_disturbance: BTreeMap::from([("push".to_string(), score())]),
        }];
        let svg = curve(&sweep, &cards, &runs);
        assert!(svg.contains("mpc: push = 0 (N s): success"));
        assert!(svg.contains("mpc: push = 1 (N s): failure"));
        let bad = text.replace("mpc,push,1,2,0", "mpc,push,1,2,yes");
        let err = read_runs("runs.csv", &bad).err().unwrap().to_string();
        assert!(
            err.contains("line 4, success") && err.contains("yes"),
            "{err}"
        );
    }
}
