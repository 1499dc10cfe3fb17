//! The page of a parameter-study folder (a reproduction's `parameter-study/`): the grid of r2 x
//! swing time as two heat maps (the energy of eq. 18 and the positive work of the actuated joints),
//! the energy against swing time per r2, and the per-r2 summary, drawn as inline SVG from the
//! folder's files ([`crate::read_parameter_study`]). Hovering (or focusing) a cell or a point shows
//! its values with their units.

use crate::parameter_study::{status_name, ParameterStudy};
use crate::StudyCell;
use brachia::Error;
use brachia_run::view::data::html_escape;
use std::fmt::Write as _;
use std::path::Path;

const TEMPLATE: &str = include_str!("../assets/view/study.html");
const STYLE: &str = include_str!("../assets/view/study.css");

/// The page of the parameter-study folder `dir`; every file is checked as `brachia report` checks it.
pub fn study_folder_html(dir: &Path) -> Result<String, Error> {
    Ok(study_html(&crate::read_parameter_study(dir)?))
}

/// A number for the page: 4 significant digits.
fn num(v: f64) -> String {
    brachia_plot::format_number(v)
}

fn opt(v: Option<f64>, unit: &str) -> String {
    v.map_or_else(|| "-".to_string(), |v| format!("{} {unit}", num(v)))
}

/// What hovering a cell shows: where it is, its values with units and how the solve went.
fn cell_tip(c: &StudyCell) -> String {
    let mut s = format!(
        "r2 = {}, offset {:+} s (swing time {:.3} s): ",
        c.r2, c.offset_s, c.swing_time_s
    );
    if c.converged {
        let _ = write!(
            s,
            "energy {}, positive work {}",
            opt(c.energy_j, "J"),
            opt(c.positive_work_j, "J")
        );
    } else {
        let _ = write!(s, "did not converge ({})", status_name(&c.status));
        if let Some(k) = c.torque_scale_reached {
            let _ = write!(s, ", planned at {} x the torque limits", num(k));
        }
    }
    let _ = write!(
        s,
        "; {} iterations, {:.2} s, {} start",
        c.iterations,
        c.solve_time_s,
        serde_json::to_value(c.start)
            .ok()
            .and_then(|v| v.as_str().map(String::from))
            .unwrap_or_default()
    );
    if let Some(e) = c.replay_ee_error_m {
        let _ = write!(s, ", open-loop replay misses the bar by {e:.1e} m");
    }
    s
}

/// One heat map of the grid: `value` of each cell (`None`: failed, hatched), x = r2, y = offset.
fn heat_map(
    st: &ParameterStudy,
    id: &str,
    caption: &str,
    unit: &str,
    value: impl Fn(&StudyCell) -> Option<f64>,
) -> String {
    let (r2, off) = (&st.settings.r2, &st.settings.offsets_s);
    let (nx, ny) = (r2.len(), off.len());
    // rows at least 26 px, the grid at least 190 px high (room for the rotated y label)
    let (cw, ch, l, top, bot, bar) = (
        56.0,
        f64::max(26.0, 190.0 / ny as f64),
        58.0,
        8.0,
        40.0,
        70.0,
    );
    let (w, h) = (l + cw * nx as f64 + bar, top + ch * ny as f64 + bot);
    let vals: Vec<f64> = st.cells.iter().filter_map(&value).collect();
    let (lo, hi) = vals
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let frac = |v: f64| if hi > lo { (v - lo) / (hi - lo) } else { 0.5 };
    let colour = |t: f64| {
        let c = brachia_plot::value_colour(t);
        let light = 0.299 * c.0 as f64 + 0.587 * c.1 as f64 + 0.114 * c.2 as f64 > 128.0;
        (format!("rgb({},{},{})", c.0, c.1, c.2), light)
    };
    let mut s = format!(
        "<figure class=\"curve map\" id=\"{id}\"><figcaption>{caption} ({unit})</figcaption>\
         <svg viewBox=\"0 0 {w} {h}\" style=\"width: {w}px\" role=\"img\" aria-label=\"{caption} \
         over r2 and the offset of the swing time\"><defs><pattern id=\"{id}-hatch\" width=\"6\" height=\"6\" \
         patternUnits=\"userSpaceOnUse\" patternTransform=\"rotate(45)\"><rect width=\"6\" \
         height=\"6\" class=\"failed\"/><line x1=\"0\" y1=\"0\" x2=\"0\" y2=\"6\" \
         class=\"hatch\"/></pattern></defs>"
    );
    for ix in 0..nx {
        for iy in 0..ny {
            let c = st.cell(ix, iy);
            // row 0 (the shortest swing) at the bottom, as in the PNG heat map
            let (x, y) = (l + cw * ix as f64, top + ch * (ny - 1 - iy) as f64);
            let tip = html_escape(&cell_tip(c));
            let (fill, text, light) = match value(c) {
                Some(v) => {
                    let (f, light) = colour(frac(v));
                    (f, num(v), light)
                }
                None => (format!("url(#{id}-hatch)"), "failed".to_string(), true),
            };
            let _ = write!(
                s,
                "<g class=\"cell\" tabindex=\"0\" data-r2=\"{}\" data-offset=\"{}\" data-value=\"{}\" \
                 data-tip=\"{tip}\" aria-label=\"{tip}\"><rect x=\"{x:.1}\" y=\"{y:.1}\" \
                 width=\"{cw}\" height=\"{ch}\" fill=\"{fill}\"/><text x=\"{:.1}\" y=\"{:.1}\" \
                 text-anchor=\"middle\" class=\"{}\">{text}</text></g>",
                c.r2,
                c.offset_s,
                value(c).map(|v| v.to_string()).unwrap_or_default(),
                x + cw / 2.0,
                y + ch / 2.0 + 4.0,
                if light { "on-light" } else { "on-dark" }
            );
        }
    }
    for (ix, v) in r2.iter().enumerate() {
        let _ = write!(
            s,
            "<text class=\"tick\" x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{v}</text>",
            l + cw * (ix as f64 + 0.5),
            top + ch * ny as f64 + 14.0
        );
    }
    let _ = write!(
        s,
        "<text class=\"tick\" x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">r2 = L1 / (L1 + L2)</text>",
        l + cw * nx as f64 / 2.0,
        h - 6.0
    );
    for (iy, v) in off.iter().enumerate() {
        let _ = write!(
            s,
            "<text class=\"tick\" x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{v:+}</text>",
            l - 4.0,
            top + ch * (ny - 1 - iy) as f64 + ch / 2.0 + 4.0
        );
    }
    let _ = write!(
        s,
        "<text class=\"tick\" transform=\"translate(12 {:.1}) rotate(-90)\" text-anchor=\"middle\">\
         swing time - 2 T_freefall (s)</text>",
        top + ch * ny as f64 / 2.0
    );
    // the colour scale: its range in the unit
    if !vals.is_empty() {
        let (bx, bh) = (l + cw * nx as f64 + 12.0, ch * ny as f64);
        for k in 0..20 {
            let (f, _) = colour(1.0 - k as f64 / 19.0);
            let _ = write!(
                s,
                "<rect x=\"{bx:.1}\" y=\"{:.1}\" width=\"14\" height=\"{:.2}\" fill=\"{f}\"/>",
                top + bh * k as f64 / 20.0,
                bh / 20.0 + 0.5
            );
        }
        let _ = write!(
            s,
            "<text class=\"tick\" x=\"{:.1}\" y=\"{:.1}\">{} {unit}</text>\
             <text class=\"tick\" x=\"{:.1}\" y=\"{:.1}\">{} {unit}</text>",
            bx + 18.0,
            top + 10.0,
            num(hi),
            bx + 18.0,
            top + bh,
            num(lo)
        );
    }
    s.push_str("</svg></figure>");
    s
}

/// The energy against the swing time, one line per r2 (converged cells only).
fn energy_curves(st: &ParameterStudy) -> String {
    let pts: Vec<(usize, &StudyCell, f64)> = st
        .cells
        .iter()
        .enumerate()
        .filter_map(|(k, c)| c.energy_j.map(|e| (k / st.settings.offsets_s.len(), c, e)))
        .collect();
    if pts.is_empty() {
        return String::new();
    }
    let fold = |f: &dyn Fn(&(usize, &StudyCell, f64)) -> f64| {
        pts.iter()
            .map(f)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let (x0, x1) = fold(&|p| p.1.swing_time_s);
    let (y0, y1) = fold(&|p| p.2);
    let (w, h, l, rgt, top, bot) = (560.0, 300.0, 56.0, 12.0, 10.0, 40.0);
    let sx = |x: f64| l + (w - l - rgt) * if x1 > x0 { (x - x0) / (x1 - x0) } else { 0.5 };
    let sy = |y: f64| top + (h - top - bot) * if y1 > y0 { (y1 - y) / (y1 - y0) } else { 0.5 };
    let mut s = format!(
        "<figure class=\"curve\" id=\"energy-curves\"><figcaption>energy (J) against swing time \
         (s), one line per r2</figcaption><svg viewBox=\"0 0 {w} {h}\" role=\"img\" \
         aria-label=\"energy against swing time, one line per r2\">"
    );
    for (v, y) in [(y0, sy(y0)), (y1, sy(y1))] {
        let _ = write!(
            s,
            "<line class=\"grid\" x1=\"{l}\" x2=\"{}\" y1=\"{y:.1}\" y2=\"{y:.1}\"/><text \
             class=\"tick\" x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{} J</text>",
            w - rgt,
            l - 4.0,
            y + 4.0,
            num(v)
        );
    }
    let _ = write!(
        s,
        "<text class=\"tick\" x=\"{l}\" y=\"{:.1}\">{} s</text><text class=\"tick\" x=\"{:.1}\" \
         y=\"{:.1}\" text-anchor=\"end\">{} s</text><text class=\"tick\" x=\"{:.1}\" y=\"{:.1}\" \
         text-anchor=\"middle\">swing time (s)</text>",
        h - bot + 14.0,
        num(x0),
        w - rgt,
        h - bot + 14.0,
        num(x1),
        (l + w - rgt) / 2.0,
        h - 6.0
    );
    for (i, row) in st.rows.iter().enumerate() {
        let mine: Vec<&(usize, &StudyCell, f64)> = pts.iter().filter(|p| p.0 == i).collect();
        let line: Vec<String> = mine
            .iter()
            .map(|p| format!("{:.1},{:.1}", sx(p.1.swing_time_s), sy(p.2)))
            .collect();
        let _ = write!(
            s,
            "<polyline class=\"s{}\" points=\"{}\"/>",
            i % 8,
            line.join(" ")
        );
        for p in mine {
            let tip = html_escape(&cell_tip(p.1));
            let _ = write!(
                s,
                "<circle class=\"s{} pt\" tabindex=\"0\" cx=\"{:.1}\" cy=\"{:.1}\" r=\"3.5\" \
                 data-r2=\"{}\" data-tip=\"{tip}\" aria-label=\"{tip}\"/>",
                i % 8,
                sx(p.1.swing_time_s),
                sy(p.2),
                row.r2
            );
        }
    }
    s.push_str("</svg></figure>");
    s
}

/// The per-r2 table: link lengths, free-fall and swing time, energy at T and the lowest energy.
fn rows_table(st: &ParameterStudy) -> String {
    let mut s = String::from(
        "<table id=\"rows\"><thead><tr><th>r2</th><th>link lengths (m)</th><th>T_freefall (s)</th>\
         <th>T = 2 T_freefall (s)</th><th>energy at T (J)</th><th>lowest energy (J)</th>\
         <th>at swing time (s)</th><th>failed cells</th></tr></thead><tbody>",
    );
    for r in &st.rows {
        let lengths: Vec<String> = r.lengths_m.iter().map(|l| format!("{l:.3}")).collect();
        let _ = write!(
            s,
            "<tr><td>{}</td><td>{}</td><td>{:.3}</td><td>{:.3}</td><td>{}</td><td>{}</td><td>{}{}</td>\
             <td>{}</td></tr>",
            r.r2,
            lengths.join(", "),
            r.freefall_time_s,
            r.swing_time_s,
            r.energy_at_t_j.map_or("-".into(), num),
            r.min_energy_j.map_or("-".into(), num),
            r.argmin_swing_time_s.map_or("-".into(), |t| format!("{t:.3}")),
            if r.argmin_at_edge == Some(true) {
                " (grid edge)"
            } else {
                ""
            },
            r.failed_cells
        );
    }
    s.push_str("</tbody></table>");
    s
}

/// The page of the study `st`.
pub fn study_html(st: &ParameterStudy) -> String {
    let (nx, ny) = (st.settings.r2.len(), st.settings.offsets_s.len());
    let title = format!("{}: parameter study", st.base.name);
    let subtitle = format!(
        "{nx} r2 x {ny} swing times ({} cells, {} did not converge); arms of {} m; energy: paper \
         eq. (18), J",
        st.cells.len(),
        st.failed_cells(),
        st.settings.arm_length_m
    );
    let maps = heat_map(st, "energy-map", "energy of the optimal swing", "J", |c| {
        c.energy_j
    }) + &heat_map(
        st,
        "work-map",
        "positive work of the actuated joints",
        "J",
        |c| c.positive_work_j,
    );
    let mut legend = String::new();
    for (i, r) in st.rows.iter().enumerate() {
        let _ = write!(
            legend,
            "<li><span class=\"sw\" style=\"background: var(--s{})\"></span>r2 = {}</li>",
            i % 8,
            r.r2
        );
    }
    let body = TEMPLATE
        .replace("{{HEADER}}", &brachia_run::view::header(&title, &subtitle))
        .replace("{{MAPS}}", &maps)
        .replace("{{LEGEND}}", &legend)
        .replace("{{CURVES}}", &energy_curves(st))
        .replace("{{ROWS}}", &rows_table(st));
    brachia_run::view::page(&title, STYLE, &body)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parameter_study::{
        parameter_study_folder, BaseParams, CellStart, ParameterStudySettings,
    };
    use crate::StudyRow;
    use brachia::planning::SolveStatus;

    /// A 2 r2 x 2 offsets study whose cell (r2 0.5, offset +0.2) did not converge.
    fn study() -> ParameterStudy {
        let settings = ParameterStudySettings {
            r2: vec![0.4, 0.5],
            offsets_s: vec![0.0, 0.2],
            stick_r2: Vec::new(),
            ..ParameterStudySettings::default()
        };
        let base = BaseParams::Paper.load().unwrap();
        let cell = |r2: f64, offset_s: f64, energy: Option<f64>| StudyCell {
            r2,
            offset_s,
            swing_time_s: 1.5 + offset_s,
            status: if energy.is_some() {
                SolveStatus::Solved
            } else {
                SolveStatus::MaxIterations
            },
            converged: energy.is_some(),
            energy_j: energy,
            positive_work_j: energy.map(|e| e + 0.25),
            objective: energy,
            iterations: 17,
            solve_time_s: 0.5,
            start: CellStart::Cold,
            replay_ee_error_m: Some(1e-4),
            torque_scale_reached: None,
        };
        let row = |r2: f64, e: f64| StudyRow {
            r2,
            lengths_m: vec![0.71 * r2, 0.71 * (1.0 - r2), 0.71 * (1.0 - r2), 0.71 * r2],
            start_q: Vec::new(),
            freefall_time_s: 0.75,
            swing_time_s: 1.5,
            energy_at_t_j: Some(e),
            argmin_swing_time_s: Some(1.5),
            argmin_offset_s: Some(0.0),
            min_energy_j: Some(e),
            argmin_at_edge: Some(true),
            failed_cells: usize::from(r2 == 0.5),
        };
        ParameterStudy {
            settings,
            base,
            start_q: vec![-2.35, 0.0, -1.55, 0.0],
            rows: vec![row(0.4, 1.25), row(0.5, 2.5)],
            cells: vec![
                cell(0.4, 0.0, Some(1.25)),
                cell(0.4, 0.2, Some(1.75)),
                cell(0.5, 0.0, Some(2.5)),
                cell(0.5, 0.2, None),
            ],
            sticks: Vec::new(),
            wall_time_s: 2.0,
        }
    }

    #[test]
    fn the_study_folder_page_shows_every_cell_with_its_values_and_refuses_a_tampered_file() {
        let dir = tempfile::tempdir().unwrap();
        parameter_study_folder(&study())
            .write_into(dir.path())
            .unwrap();
        let page = crate::view::view_html(dir.path()).unwrap();
        // two heat maps of four cells, each cell naming its place, value and unit on hover
        assert_eq!(page.matches("<g class=\"cell\"").count(), 8);
        assert!(page.contains(
            "data-tip=\"r2 = 0.4, offset +0.2 s (swing time 1.700 s): energy 1.75 J, positive \
             work 2 J; 17 iterations, 0.50 s, cold start"
        ));
        assert!(page.contains("did not converge (max_iterations)"));
        assert!(page.contains(">failed</text>"));
        // three converged cells on the energy curves, one line per r2
        assert_eq!(page.matches("class=\"s0 pt\"").count(), 2);
        assert_eq!(page.matches("class=\"s1 pt\"").count(), 1);
        assert!(!page.contains("http://") && !page.contains("https://"));
        assert!(page.contains("(grid edge)"));
        // a value that does not parse is refused, naming the file
        let csv = dir.path().join("cells.csv");
        let text = std::fs::read_to_string(&csv).unwrap();
        std::fs::write(&csv, text.replacen("1.250000000", "lots", 1)).unwrap();
        let err = crate::view::view_html(dir.path()).unwrap_err().to_string();
        assert!(err.contains("cells.csv") && err.contains("lots"), "{err}");
    }
}
