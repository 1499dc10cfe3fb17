//! The page data of a ladder traverse: the whole traverse in the world frame, drawn from its
//! `traverse.csv` (the chain's world joints at every row), its `report.json` (bars, swings, status)
//! and, on the rapier plant, its contacts and obstacle track; grip switches are marks in the plots.

use super::data::{
    circle, contact_json, draw_indices, r, robot_json, rv, with_full, DEFAULT_RADIUS_M,
};
use crate::ladder::Bar;
use brachia::model::Circle;
use brachia::{Error, Robot};
use brachia_rapier::{ContactEvent, Obstacle};
use serde::Deserialize;
use serde_json::{json, Value};

/// The part of a traverse's `report.json` its page draws.
#[derive(Debug, Clone, Deserialize)]
pub struct TraverseReportView {
    /// The scenario's name.
    pub scenario: String,
    /// The plant's name.
    pub plant: String,
    /// How the traverse ended, in words.
    pub message: String,
    /// The bars, world frame.
    pub bars: Vec<Bar>,
    /// The ladder's obstacles, world frame.
    #[serde(default)]
    pub obstacles: Vec<Circle>,
    /// The rapier world's obstacles (the ladder's first, then the plant's).
    #[serde(default)]
    pub plant_obstacles: Vec<Obstacle>,
    /// Every swing tracked.
    pub swings: Vec<SwingView>,
}

/// One swing of a traverse's report, as the page uses it.
#[derive(Debug, Clone, Deserialize)]
pub struct SwingView {
    /// The bar held.
    pub from_bar: usize,
    /// The bar swung to.
    pub to_bar: usize,
    /// The hand that holds: 0 = hand A, 1 = hand B.
    pub holding_hand: usize,
    /// Start time within the traverse, s.
    pub t_start_s: f64,
    /// Duration, s.
    pub duration_s: f64,
    /// Energy, eq. 18, J.
    pub energy_j: f64,
    /// Whether the bar was caught.
    pub captured: bool,
}

/// What a traverse's page draws.
#[derive(Debug, Clone, Copy)]
pub struct TraverseParts<'a> {
    /// The name of `traverse.csv` in messages.
    pub file: &'a str,
    /// `traverse.csv` after its schema line.
    pub csv: &'a str,
    /// The report.
    pub report: &'a TraverseReportView,
    /// The robot (the parameters file's chain, hand A at link 1), when known: capsule radii and
    /// torque limits.
    pub robot: Option<&'a Robot>,
    /// The links' contacts (links in the parameters file's order), traverse time.
    pub contacts: &'a [ContactEvent],
    /// Obstacle centres over time, rows `[t, x_0, y_0, ...]`.
    pub obstacle_track: &'a [Vec<f64>],
}

/// `traverse.csv` of an `n`-link chain parsed: every row's numbers, `2 n + (n - 1) + 2 + 5 + 2 (n + 1)`
/// columns.
struct Rows {
    n: usize,
    cols: usize,
    v: Vec<f64>,
}

impl Rows {
    fn at(&self, k: usize) -> &[f64] {
        &self.v[k * self.cols..(k + 1) * self.cols]
    }
    fn len(&self) -> usize {
        self.v.len() / self.cols
    }
}

/// Parse `traverse.csv` (after its schema line): the header of an n-link chain, finite numbers, times
/// that never decrease, swing indices of the report's swings, holding hands 0 or 1.
fn parse(file: &str, text: &str, swings: usize) -> Result<Rows, Error> {
    let text = crate::read::strip_bom(text);
    let mut lines = text.lines();
    let got = lines.next().unwrap_or("").trim();
    let n = got.split(',').filter(|c| c.starts_with("qd")).count();
    let want = crate::traverse::csv_header(n.max(2));
    if n < 2 || got != want {
        return Err(Error::invalid(
            file,
            "header",
            got.chars().take(160).collect::<String>(),
            "expected t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,swing,holding_hand,grip_bar,grip_x,\
             grip_y,hand_a_x,hand_a_y,p1_x,p1_y,...,hand_b_x,hand_b_y (n >= 2 links)",
        ));
    }
    let names: Vec<&str> = want.split(',').collect();
    let cols = names.len();
    let mut v = Vec::new();
    let mut last_t = f64::NEG_INFINITY;
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        // line numbers of the file: the schema line, the header, then the rows
        let at = |c: &str| format!("line {}, {c}", i + 3);
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != cols {
            return Err(Error::invalid(
                file,
                format!("line {}", i + 3),
                line.chars().take(160).collect::<String>(),
                format!("expected {cols} columns"),
            ));
        }
        for (cell, name) in cells.iter().zip(&names) {
            let x = cell
                .parse::<f64>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| Error::invalid(file, at(name), *cell, "must be a finite number"))?;
            v.push(x);
        }
        let row = &v[v.len() - cols..];
        if row[0] < last_t {
            return Err(Error::invalid(
                file,
                at("t"),
                cells[0],
                format!("times must not decrease (the row before: {last_t} s)"),
            ));
        }
        last_t = row[0];
        let s = 3 * n + 2; // the swing column
        if row[s].fract() != 0.0 || row[s] < 0.0 || row[s] as usize >= swings {
            return Err(Error::invalid(
                file,
                at("swing"),
                cells[s],
                format!("a swing of the report: 0..{}", swings.saturating_sub(1)),
            ));
        }
        if row[s + 1] != 0.0 && row[s + 1] != 1.0 {
            return Err(Error::invalid(
                file,
                at("holding_hand"),
                cells[s + 1],
                "0 (hand A) or 1 (hand B)",
            ));
        }
    }
    if v.len() < 2 * cols {
        return Err(Error::invalid(
            file,
            "rows",
            v.len() / cols,
            "a traverse has at least two rows",
        ));
    }
    Ok(Rows { n, cols, v })
}

/// The page data of a traverse.
pub fn traverse_view(p: TraverseParts<'_>) -> Result<Value, Error> {
    let rep = p.report;
    let rows = parse(p.file, p.csv, rep.swings.len())?;
    let (n, len) = (rows.n, rows.len());
    if let Some(robot) = p.robot.filter(|rb| rb.n() != n) {
        return Err(Error::invalid(
            p.file,
            "header",
            format!("{n} links"),
            format!("the robot has {} links", robot.n()),
        ));
    }
    let sw = 3 * n + 2; // the swing column
    let t: Vec<f64> = (0..len).map(|k| rows.at(k)[0]).collect();
    // eq. 18 and the positive work over the rows of each swing (the grip switch is no motion)
    let (mut e, mut w) = (vec![0.0; len], vec![0.0; len]);
    for k in 1..len {
        let (a, b) = (rows.at(k - 1), rows.at(k));
        let (mut de, mut dw) = (0.0, 0.0);
        if a[sw] == b[sw] {
            for j in 1..n {
                let pw = a[2 * n + j] * (b[1 + j] - a[1 + j]);
                de += pw;
                dw += pw.max(0.0);
            }
        }
        e[k] = e[k - 1] + de;
        w[k] = w[k - 1] + dw;
    }
    // the drawing samples and both rows of every grip switch
    let mut idx = draw_indices(&t);
    for k in 1..len {
        if rows.at(k)[sw] != rows.at(k - 1)[sw] {
            idx.extend([k - 1, k]);
        }
    }
    idx.sort_unstable();
    idx.dedup();
    let pick = |idx: &[usize], cols: std::ops::Range<usize>| -> Vec<Vec<f64>> {
        idx.iter().map(|&k| rv(&rows.at(k)[cols.clone()])).collect()
    };
    // world joints in the order of the chain that holds (grip first)
    let pts: Vec<Vec<f64>> = idx
        .iter()
        .map(|&k| {
            let row = rows.at(k);
            let hold = row[sw + 1] as usize;
            let mut pts: Vec<&[f64]> = row[sw + 5..].chunks(2).collect();
            if hold == 1 {
                pts.reverse();
            }
            pts.concat().into_iter().map(r).collect()
        })
        .collect();
    let bars: Vec<Vec<f64>> = rep.bars.iter().map(|b| rv(&b.p())).collect();
    let mut obstacles: Vec<Value> = rep
        .obstacles
        .iter()
        .map(|c| circle(c.center, c.radius, "planned"))
        .collect();
    for o in &rep.plant_obstacles {
        let (c, radius) = o.shape();
        let kind = match o {
            Obstacle::Ball(_) => "ball",
            Obstacle::Circle(_) => "plant",
        };
        obstacles.push(circle(c, radius, kind));
    }
    let tt: Vec<f64> = p.obstacle_track.iter().map(|row| row[0]).collect();
    let obstacle_track: Vec<Vec<f64>> = draw_indices(&tt)
        .iter()
        .map(|&k| rv(&p.obstacle_track[k]))
        .collect();
    let hand = |h: usize| if h == 0 { "A" } else { "B" };
    let switches: Vec<Value> = rep
        .swings
        .iter()
        .map(|s| {
            let t1 = s.t_start_s + s.duration_s;
            let text = if s.captured {
                format!(
                    "grip switch: hand {} caught bar {} (swing energy {:.3} J)",
                    hand(1 - s.holding_hand),
                    s.to_bar,
                    s.energy_j
                )
            } else {
                format!("bar {} missed", s.to_bar)
            };
            json!({ "t": r(t1), "text": text })
        })
        .collect();
    let swings: Vec<Value> = rep
        .swings
        .iter()
        .map(|s| {
            json!({ "t0": r(s.t_start_s), "t1": r(s.t_start_s + s.duration_s),
                    "from": s.from_bar, "to": s.to_bar })
        })
        .collect();
    let contacts: Vec<Value> = p.contacts.iter().map(contact_json).collect();
    let robot = match p.robot {
        Some(robot) => robot_json(robot),
        None => json!({ "n": n, "lengths": [], "radii": vec![DEFAULT_RADIUS_M; n],
                        "tau_min": [], "tau_max": [] }),
    };
    let mut notes = Vec::new();
    if p.robot.is_none() {
        notes.push(format!(
            "The links are drawn {DEFAULT_RADIUS_M} m thick and without torque limits: the folder \
             does not name the robot's parameters file."
        ));
    }
    let last = rep.bars.last().map(|b| rv(&b.p()));
    let mut data = json!({
        "schema": super::VIEW_SCHEMA,
        "kind": "traverse",
        "title": rep.scenario,
        "subtitle": format!(
            "traverse on the {} plant: {}; {} swing(s), energy {:.3} J",
            rep.plant,
            rep.message,
            rep.swings.len(),
            rep.swings.iter().map(|s| s.energy_j).sum::<f64>()
        ),
        "notes": notes,
        "robot": robot,
        "bars": bars,
        "target": last,
        "obstacles": obstacles,
        "obstacle_track": obstacle_track,
        "pts": pts,
        "hold": idx.iter().map(|&k| rows.at(k)[sw + 1] as u8).collect::<Vec<_>>(),
        "swings": swings,
        "switches": switches,
        "contacts": contacts,
    });
    let series = |idx: &[usize]| {
        let m = json!({
            "t": idx.iter().map(|&k| r(t[k])).collect::<Vec<_>>(),
            "q": pick(idx, 1..1 + n),
            "qd": pick(idx, 1 + n..1 + 2 * n),
            "tau": pick(idx, 1 + 2 * n..3 * n),
            "energy": idx.iter().map(|&k| r(e[k])).collect::<Vec<_>>(),
            "work": idx.iter().map(|&k| r(w[k])).collect::<Vec<_>>(),
        });
        m.as_object().cloned().unwrap_or_default()
    };
    with_full(&mut data, len, &idx, &series);
    Ok(data)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(swings: usize) -> TraverseReportView {
        let sw = |k: usize| SwingView {
            from_bar: k,
            to_bar: k + 1,
            holding_hand: k % 2,
            t_start_s: k as f64,
            duration_s: 1.0,
            energy_j: 0.5,
            captured: true,
        };
        TraverseReportView {
            scenario: "ladder".into(),
            plant: "model".into(),
            message: "completed".into(),
            bars: (0..=swings)
                .map(|k| Bar {
                    x: k as f64,
                    y: 0.0,
                })
                .collect(),
            obstacles: Vec::new(),
            plant_obstacles: Vec::new(),
            swings: (0..swings).map(sw).collect(),
        }
    }

    /// A two-link traverse of `swings` swings, 1 s each at 1 ms, every row with the chain hanging
    /// straight down from its grip bar: `hand` of each swing moved by `dy` to make a tampered row.
    fn csv(swings: usize) -> String {
        let mut s = crate::traverse::csv_header(2) + "\n";
        for k in 0..swings {
            for i in 0..=1000 {
                let t = k as f64 + i as f64 * 1e-3;
                let g = k as f64;
                s.push_str(&format!(
                    "{t},-1.5707963,0,0,0,0.1,{g},-1,{k},{},{k},{g},0,{g},0,{g},-0.5,{g},-1\n",
                    k % 2
                ));
            }
        }
        s
    }

    #[test]
    fn a_traverse_keeps_both_rows_of_every_switch_and_re_roots_the_chain() {
        let rep = report(2);
        let text = csv(2);
        let v = traverse_view(TraverseParts {
            file: "traverse.csv",
            csv: &text,
            report: &rep,
            robot: None,
            contacts: &[],
            obstacle_track: &[],
        })
        .unwrap();
        let t: Vec<f64> = serde_json::from_value(v["t"].clone()).unwrap();
        let hold: Vec<u8> = serde_json::from_value(v["hold"].clone()).unwrap();
        // the switch at 1 s: two samples at the same time, the first held by hand A, the second by B
        let k = t.iter().position(|&x| x == 1.0).unwrap();
        assert_eq!(t[k + 1], 1.0);
        assert_eq!((hold[k], hold[k + 1]), (0, 1));
        // hand B holds: the grip (first point) is hand B's end, (1, -1) in the rows written
        let pts: Vec<Vec<f64>> = serde_json::from_value(v["pts"].clone()).unwrap();
        assert_eq!(&pts[k + 1][..2], &[1.0, -1.0]);
        assert_eq!(&pts[k][..2], &[0.0, 0.0]);
        assert_eq!(v["switches"].as_array().unwrap().len(), 2);
        assert_eq!(v["target"], json!([2.0, 0.0]));
        // eq. 18 of tau2 = 0.1 N m while q2 does not move: no energy
        assert_eq!(v["energy"].as_array().unwrap().last().unwrap(), &json!(0.0));
    }

    #[test]
    fn a_tampered_traverse_csv_is_refused_naming_line_and_column() {
        let rep = report(2);
        let mut text = csv(2);
        text = text.replacen("0.1,0,-1,0,0", "0.1,0,-1,7,0", 1);
        let err = traverse_view(TraverseParts {
            file: "traverse.csv",
            csv: &text,
            report: &rep,
            robot: None,
            contacts: &[],
            obstacle_track: &[],
        })
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("traverse.csv") && err.contains("line 3, swing"),
            "{err}"
        );
        let bad = csv(1).replacen("0.1", "nan", 1);
        let err = traverse_view(TraverseParts {
            file: "traverse.csv",
            csv: &bad,
            report: &report(1),
            robot: None,
            contacts: &[],
            obstacle_track: &[],
        })
        .unwrap_err()
        .to_string();
        assert!(err.contains("line 3, tau2") && err.contains("nan"), "{err}");
    }
}
