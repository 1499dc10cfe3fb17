//! The Monte Carlo families on the benchmark page: a table of the success rate per family and
//! controller with each family's run count, and the same as a bar chart (inline SVG, hovering a bar
//! names the controller, the family, the rate and the runs).

use super::card::{ControllerCard, Scorecard};
use crate::view::data::html_escape;
use std::fmt::Write as _;

/// The families of the scorecard (its disturbances that are no sweep), in the benchmark's order,
/// those it does not know after them by name, each with its runs (the most any controller ran).
fn families(card: &Scorecard) -> Vec<(String, usize)> {
    let mut names: Vec<String> = Vec::new();
    for c in &card.controllers {
        for k in c.per_disturbance.keys() {
            if !card.sweeps.iter().any(|s| &s.name == k) && !names.contains(k) {
                names.push(k.clone());
            }
        }
    }
    let order: Vec<&str> = crate::families::families().iter().map(|f| f.name).collect();
    names.sort_by_key(|n| {
        (
            order.iter().position(|o| o == n).unwrap_or(order.len()),
            n.clone(),
        )
    });
    names
        .into_iter()
        .map(|n| {
            let runs = card
                .controllers
                .iter()
                .filter_map(|c| c.per_disturbance.get(&n).map(|s| s.runs))
                .max()
                .unwrap_or(0);
            (n, runs)
        })
        .collect()
}

fn pct(c: &ControllerCard, family: &str) -> Option<(f64, usize)> {
    c.per_disturbance
        .get(family)
        .map(|s| (s.success_pct, s.runs))
}

/// The section's HTML (`legend`: the page's list items naming the controllers' colours): empty
/// when the benchmark ran no family.
pub(super) fn section(card: &Scorecard, legend: &str) -> String {
    let fams = families(card);
    if fams.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "<h2>Success per Monte Carlo family (rapier plant; hover a bar for its runs)</h2>\
         <table id=\"families\"><thead><tr><th>family</th><th>runs</th>",
    );
    for c in &card.controllers {
        let _ = write!(s, "<th>{}</th>", html_escape(&c.controller));
    }
    s.push_str("</tr></thead><tbody>");
    for (name, runs) in &fams {
        let _ = write!(
            s,
            "<tr data-family=\"{n}\"><td>{n}</td><td>{runs}</td>",
            n = html_escape(name)
        );
        for c in &card.controllers {
            match pct(c, name) {
                Some((p, _)) => {
                    let _ = write!(s, "<td>{p:.1} %</td>");
                }
                None => s.push_str("<td>-</td>"),
            }
        }
        s.push_str("</tr>");
    }
    s.push_str("</tbody></table>");
    let _ = write!(s, "<ul class=\"legend\">{legend}</ul>");
    s.push_str(&chart(card, &fams));
    s
}

/// The bar chart: a group per family, a bar per controller, success from 0 to 100 %.
fn chart(card: &Scorecard, fams: &[(String, usize)]) -> String {
    let nc = card.controllers.len().max(1) as f64;
    let gw = 116.0;
    let (l, rgt, top, bot, h) = (44.0, 10.0, 16.0, 42.0, 240.0);
    let w = l + rgt + gw * fams.len() as f64;
    let sy = |y: f64| top + (h - top - bot) * (100.0 - y) / 100.0;
    let mut s = format!(
        "<figure class=\"families\" id=\"family-chart\"><figcaption>success per family, one \
         bar per controller</figcaption><svg viewBox=\"0 0 {w} {h}\" role=\"img\" aria-label=\"success \
         per Monte Carlo family, one bar per controller\">"
    );
    for y in [0.0, 25.0, 50.0, 75.0, 100.0] {
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
    let bw = gw * 0.8 / nc;
    for (fi, (name, runs)) in fams.iter().enumerate() {
        let g0 = l + fi as f64 * gw + 0.1 * gw;
        for (ci, c) in card.controllers.iter().enumerate() {
            let Some((p, n)) = pct(c, name) else {
                continue;
            };
            // a bar of 0 % keeps a sliver so that it can be hovered
            let y = sy(p).min(sy(0.0) - 2.0);
            let _ = write!(
                s,
                "<rect class=\"bar s{}\" data-family=\"{f}\" data-controller=\"{cn}\" x=\"{:.1}\" \
                 y=\"{y:.1}\" width=\"{:.1}\" height=\"{:.1}\"><title>{cn}: {f}: {p:.1} % of {n} \
                 run{} succeeded</title></rect>",
                ci % 8,
                g0 + ci as f64 * bw,
                (bw - 1.0).max(1.0),
                sy(0.0) - y,
                if n == 1 { "" } else { "s" },
                f = html_escape(name),
                cn = html_escape(&c.controller),
            );
        }
        let xc = l + (fi as f64 + 0.5) * gw;
        let _ = write!(
            s,
            "<text class=\"tick\" x=\"{xc:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>\
             <text class=\"tick\" x=\"{xc:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{runs} run{}</text>",
            h - bot + 14.0,
            html_escape(name),
            h - bot + 28.0,
            if *runs == 1 { "" } else { "s" }
        );
    }
    s.push_str("</svg></figure>");
    s
}

#[cfg(test)]
mod tests {
    use super::super::card::{Score, SweepDef};
    use super::*;
    use std::collections::BTreeMap;

    fn score(runs: usize, success_pct: f64) -> Score {
        Score {
            runs,
            success_pct,
            energy_j: 1.0,
            peak_torque_nm: 1.0,
            smoothness_nm: 0.1,
            final_error_m: 0.01,
        }
    }

    #[test]
    fn families_are_the_disturbances_that_are_no_sweep_in_the_benchmarks_order() {
        let card = |name: &str, mc: f64| ControllerCard {
            controller: name.into(),
            robustness_score: 0.5,
            overall: score(12, 50.0),
            per_disturbance: BTreeMap::from([
                ("mass".to_string(), score(3, 100.0)),
                ("mc_push".to_string(), score(4, 25.0)),
                ("monte_carlo".to_string(), score(5, mc)),
            ]),
        };
        let sc = Scorecard {
            scenario: "tracking".into(),
            success_radius_m: 0.02,
            capture_speed_m_s: Some(0.5),
            sweeps: vec![SweepDef {
                name: "mass".into(),
                level: "x".into(),
                levels: vec![1.0, 1.2, 1.4],
            }],
            controllers: vec![card("mpc", 80.0), card("pd", 20.0)],
        };
        assert_eq!(
            families(&sc),
            vec![("monte_carlo".to_string(), 5), ("mc_push".to_string(), 4)]
        );
        let html = section(&sc, "");
        assert_eq!(html.matches("<tr data-family=").count(), 2);
        assert_eq!(html.matches("<rect class=\"bar").count(), 4);
        assert!(html.contains("<title>pd: monte_carlo: 20.0 % of 5 runs succeeded</title>"));
        assert!(html.contains("<td>monte_carlo</td><td>5</td><td>80.0 %</td><td>20.0 %</td>"));
        // a benchmark of sweeps alone has no such section
        let mut sweeps_only = sc;
        for c in &mut sweeps_only.controllers {
            c.per_disturbance.retain(|k, _| k == "mass");
        }
        assert_eq!(section(&sweeps_only, ""), "");
    }
}
