//! The parameter study's part of the reproduction (paper V-A, Figs. 3 and 4): the grid it runs, its
//! figures, its rows of the comparison table and its section of the report.
//!
//! Units: s, m, J. r2 = L1 / (L1 + L2), the lower arm's share of an arm's length.

use super::figures::FigureDir;
use crate::parameter_study::{BaseParams, ParameterStudy, ParameterStudySettings};
use crate::scenario::LoadedScenario;
use brachia_plot::{
    heatmap, line_plot, stick_diagram, Heatmap, LinePlot, PlotError, Series, StickOptions,
};
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::Path;

/// Iteration cap of one solve in the study. Converged cells need 10-40 iterations on `ocp` (fewer
/// warm-started); a cell that does not converge would otherwise run to the solver's default 500
/// iterations in each of its attempts (warm, cold, other guesses) and dominate the run time.
const STUDY_MAX_ITER: usize = 200;

/// The study the reproduction runs: the paper's 9 x 11 grid on the robot of the tracking scenario with
/// the tracking scenario's planner mesh and solver (multiple shooting on `ocp` by default;
/// docs/parameter-study.md), or (`quick`) 3 r2 x 3 swing times.
pub(crate) fn settings(tracking: &LoadedScenario, quick: bool) -> ParameterStudySettings {
    let sc = &tracking.scenario;
    let mut s = ParameterStudySettings {
        base_params: BaseParams::File(sc.params.clone()),
        solver: sc.solver.clone(),
        ..ParameterStudySettings::default()
    };
    s.planner.transcription = sc.planner.transcription;
    s.planner.knot_dt = sc.planner.knot_dt;
    s.planner.shooting = sc.planner.shooting.clone();
    s.solver.max_iter = STUDY_MAX_ITER;
    if quick {
        s.r2 = vec![0.2, 0.5, 0.8];
        s.offsets_s = vec![-0.5, 0.0, 0.5];
    }
    s
}

/// File stem of the stick diagram of `r2` (`fig4b_stick_r2_0_20`), named like the study's CSVs.
fn stick_name(r2: f64) -> String {
    format!(
        "fig4b_stick_r2_{}",
        crate::parameter_study::r2_tag(r2).replace('.', "_")
    )
}

/// Heat-map values in the plot's layout (`values[iy * xs.len() + ix]`, x = r2, y = offset) of one
/// quantity of the cells.
fn grid(st: &ParameterStudy, value: impl Fn(&crate::StudyCell) -> Option<f64>) -> Vec<Option<f64>> {
    let (nx, ny) = (st.settings.r2.len(), st.settings.offsets_s.len());
    let mut v = vec![None; nx * ny];
    for ix in 0..nx {
        for iy in 0..ny {
            v[iy * nx + ix] = value(st.cell(ix, iy));
        }
    }
    v
}

/// Figs. 3 and 4: the energy heat map, energy against swing time per r2, T against r2, and the stick
/// diagrams of a short and a long lower arm.
pub(crate) fn draw_figures(
    st: &ParameterStudy,
    figs: &mut FigureDir,
) -> Vec<(String, Result<(), PlotError>)> {
    let mut out = Vec::new();
    out.push((
        "fig3".to_string(),
        heatmap(
            figs.png("fig3_energy_heatmap"),
            &Heatmap {
                title: "Parameter study (V-A): energy of the optimal swing, eq. (18)".into(),
                x_label: "r2 = L1 / (L1 + L2)".into(),
                y_label: "swing time - 2 T_freefall (s)".into(),
                xs: st.settings.r2.clone(),
                ys: st.settings.offsets_s.clone(),
                values: grid(st, |c| c.energy_j),
                colourbar_label: "energy (J)".into(),
                size: None,
            },
        ),
    ));
    out.push((
        "fig3c".to_string(),
        heatmap(
            figs.png("fig3c_positive_work_heatmap"),
            &Heatmap {
                title: "Parameter study (V-A): positive work of the actuated joints".into(),
                x_label: "r2 = L1 / (L1 + L2)".into(),
                y_label: "swing time - 2 T_freefall (s)".into(),
                xs: st.settings.r2.clone(),
                ys: st.settings.offsets_s.clone(),
                values: grid(st, |c| c.positive_work_j),
                colourbar_label: "positive work (J)".into(),
                size: None,
            },
        ),
    ));
    let curves: Vec<Series> = st
        .rows
        .iter()
        .enumerate()
        .filter_map(|(i, row)| {
            let (x, y): (Vec<f64>, Vec<f64>) = (0..st.settings.offsets_s.len())
                .filter_map(|j| {
                    let c = st.cell(i, j);
                    c.energy_j.map(|e| (c.swing_time_s, e))
                })
                .unzip();
            (!x.is_empty()).then(|| Series::new(format!("r2 = {}", row.r2), x, y).colour(i))
        })
        .collect();
    if !curves.is_empty() {
        out.push((
            "fig3b".to_string(),
            line_plot(
                figs.png("fig3b_energy_vs_swing_time"),
                &LinePlot {
                    title: "Parameter study (V-A): energy against swing time".into(),
                    x_label: "swing time (s)".into(),
                    y_label: "energy (J)".into(),
                    series: curves,
                    size: None,
                },
            ),
        ));
    }
    let r2: Vec<f64> = st.rows.iter().map(|r| r.r2).collect();
    out.push((
        "fig4a".to_string(),
        line_plot(
            figs.png("fig4a_swing_time"),
            &LinePlot {
                title: "Parameter study (V-A): swing time T = 2 T_freefall".into(),
                x_label: "r2 = L1 / (L1 + L2)".into(),
                y_label: "time (s)".into(),
                series: vec![
                    Series::new(
                        "T = 2 T_freefall",
                        r2.clone(),
                        st.rows.iter().map(|r| r.swing_time_s).collect(),
                    )
                    .colour(0),
                    Series::new(
                        "T_freefall",
                        r2,
                        st.rows.iter().map(|r| r.freefall_time_s).collect(),
                    )
                    .dashed()
                    .colour(1),
                ],
                size: None,
            },
        ),
    ));
    for s in &st.sticks {
        let name = stick_name(s.r2);
        let title = format!(
            "Parameter study (V-A): r2 = {}, T = {:.2} s, energy {}",
            s.r2,
            s.swing_time_s,
            s.energy_j
                .map_or("- (not converged)".into(), |e| format!("{e:.2} J"))
        );
        out.push((
            name.clone(),
            stick_diagram(
                figs.png(&name),
                &s.robot,
                &s.trajectory,
                &StickOptions {
                    title,
                    // about 20 poses whatever the swing time (T grows with r2)
                    every_s: (s.swing_time_s / 20.0).max(0.05),
                    bars: vec![[0.0, 0.0], st.settings.start],
                    target: Some(st.settings.target),
                    ..StickOptions::default()
                },
            ),
        ));
    }
    out
}

/// Positive work of the actuated joints at offset 0 (the swing at T) per r2 row, J.
fn positive_work_at_t(st: &ParameterStudy) -> Vec<Option<f64>> {
    (0..st.rows.len())
        .map(|i| {
            (0..st.settings.offsets_s.len())
                .map(|j| st.cell(i, j))
                .find(|c| c.offset_s.abs() < 1e-9)
                .and_then(|c| c.positive_work_j)
        })
        .collect()
}

/// How a sequence over r2 moves, ignoring absent values: `(rising steps, steps)`, `None` for fewer than
/// two values.
fn rises(v: &[Option<f64>]) -> Option<(usize, usize)> {
    let x: Vec<f64> = v.iter().flatten().copied().collect();
    (x.len() >= 2).then(|| (x.windows(2).filter(|w| w[1] >= w[0]).count(), x.len() - 1))
}

fn list(v: impl Iterator<Item = Option<f64>>, digits: usize) -> String {
    v.map(|x| x.map_or("-".into(), |x| format!("{x:.digits$}")))
        .collect::<Vec<_>>()
        .join(", ")
}

/// "holds" when every step rises, else how many do.
fn verdict(r: Option<(usize, usize)>) -> String {
    match r {
        Some((k, m)) if k == m => "holds".into(),
        Some((k, m)) => format!("does not hold ({k} of {m} steps rise)"),
        None => "not enough converged cells".into(),
    }
}

/// The trends of the paper's three conclusions, as rows `(quantity, paper, ours, note)`.
pub(crate) fn trend_rows(st: &ParameterStudy) -> Vec<(String, String, String, String)> {
    let rows = &st.rows;
    let r2 = rows
        .iter()
        .map(|r| format!("{}", r.r2))
        .collect::<Vec<_>>()
        .join(", ");
    let tf = rises(
        &rows
            .iter()
            .map(|r| Some(r.freefall_time_s))
            .collect::<Vec<_>>(),
    );
    let e = rises(&rows.iter().map(|r| r.energy_at_t_j).collect::<Vec<_>>());
    let wp = positive_work_at_t(st);
    let w = rises(&wp);
    let amin = rises(
        &rows
            .iter()
            .map(|r| r.argmin_swing_time_s)
            .collect::<Vec<_>>(),
    );
    let inside = rows
        .iter()
        .filter(|r| r.argmin_at_edge == Some(false))
        .count();
    let with_min = rows.iter().filter(|r| r.argmin_at_edge.is_some()).count();
    vec![
        (
            "T_freefall grows with r2 (Fig. 4a)".into(),
            "grows".into(),
            format!("{}: {} s", verdict(tf), list(rows.iter().map(|r| Some(r.freefall_time_s)), 3)),
            format!("r2 = {r2}"),
        ),
        (
            "a shorter lower arm costs less energy (Fig. 3)".into(),
            "lowest at r2 = 0.2, small difference to 0.5".into(),
            format!("{}: E(T) = {} J", verdict(e), list(rows.iter().map(|r| r.energy_at_t_j), 2)),
            "energy at T = 2 T_freefall per r2; masses, centres of mass and inertias scale with the lengths \
             (docs/parameter-study.md)"
                .into(),
        ),
        (
            "... measured as the positive work of the motors".into(),
            "(the paper's eq. (18) is the net work)".into(),
            format!("{}: W+(T) = {} J", verdict(w), list(wp.iter().copied(), 2)),
            "the integral of max(0, qd_i tau_i): the energy the motors supply when braking recovers \
             nothing; eq. (18) lets braking work cancel driving work"
                .into(),
        ),
        (
            "the energy minimum over swing time lies within [T - 0.5, T + 0.5] s".into(),
            "yes, for every r2".into(),
            format!(
                "inside the range (not at its edge) for {inside} of the {with_min} r2 with a converged cell"
            ),
            format!(
                "argmin offsets from T: {} s",
                list(rows.iter().map(|r| r.argmin_offset_s), 1)
            ),
        ),
        (
            "the minimum-energy swing time grows with r2".into(),
            "grows".into(),
            format!("{}: {} s", verdict(amin), list(rows.iter().map(|r| r.argmin_swing_time_s), 2)),
            format!("{} of {} cells did not converge", st.failed_cells(), st.cells.len()),
        ),
    ]
}

/// The study's part of `summary.json`.
pub(crate) fn summary(st: &ParameterStudy) -> Value {
    json!({
        "grid": [st.settings.r2.len(), st.settings.offsets_s.len()],
        "knot_dt_s": st.settings.planner.knot_dt,
        "transcription": st.settings.planner.transcription,
        "failed_cells": st.failed_cells(),
        "wall_time_s": st.wall_time_s,
        "rows": st.rows,
    })
}

/// The study's section of the report.
pub(crate) fn markdown(st: &ParameterStudy, figs: &Path) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Each arm is {} m long (L1 + L2 = L3 + L4); r2 = L1 / (L1 + L2) from {} to {}; masses, centres of \
         mass and inertias follow the lengths as documented in docs/parameter-study.md. Start at rest with \
         straight arms and the EE at ({}, {}), q = [{}], target ({}, {}). {} x {} cells at {} s knots \
         ({:?}), {} did not converge; {:.0} s of wall time on all cores (`parameter-study/`).\n",
        st.settings.arm_length_m,
        st.settings.r2.first().copied().unwrap_or(0.0),
        st.settings.r2.last().copied().unwrap_or(0.0),
        st.settings.start[0],
        st.settings.start[1],
        st.start_q.iter().map(|v| format!("{v:.4}")).collect::<Vec<_>>().join(", "),
        st.settings.target[0],
        st.settings.target[1],
        st.settings.r2.len(),
        st.settings.offsets_s.len(),
        st.settings.planner.knot_dt,
        st.settings.planner.transcription,
        st.failed_cells(),
        st.wall_time_s,
    );
    s.push_str("| r2 | L1 (m) | L2 (m) | T_freefall (s) | T (s) | E(T), eq. 18 (J) | positive work at T (J) | lowest-energy swing time (s) | its energy (J) | failed cells |\n|---|---|---|---|---|---|---|---|---|---|\n");
    let f = |v: Option<f64>, d: usize| v.map_or("-".into(), |x| format!("{x:.d$}"));
    let wp = positive_work_at_t(st);
    for (r, w) in st.rows.iter().zip(&wp) {
        let _ = writeln!(
            s,
            "| {} | {:.3} | {:.3} | {:.3} | {:.3} | {} | {} | {}{} | {} | {} |",
            r.r2,
            r.lengths_m.first().copied().unwrap_or(0.0),
            r.lengths_m.get(1).copied().unwrap_or(0.0),
            r.freefall_time_s,
            r.swing_time_s,
            f(r.energy_at_t_j, 3),
            f(*w, 3),
            f(r.argmin_swing_time_s, 2),
            if r.argmin_at_edge == Some(true) {
                " (edge)"
            } else {
                ""
            },
            f(r.min_energy_j, 3),
            r.failed_cells
        );
    }
    s.push('\n');
    for c in st.cells.iter().filter(|c| !c.converged) {
        let _ = write!(
            s,
            "- Failed: r2 = {}, offset {:+} s (T = {:.3} s): `{}` after {} iterations",
            c.r2,
            c.offset_s,
            c.swing_time_s,
            crate::parameter_study::status_name(&c.status),
            c.iterations
        );
        match c.torque_scale_reached {
            Some(k) => {
                let _ = writeln!(
                    s,
                    "; the planner's continuation on the torque limits converged at {k:.3}x the \
                     limits, not closer: likely torque-limited (a local estimate, not a proof)."
                );
            }
            None => s.push_str(".\n"),
        }
    }
    if st.failed_cells() > 0 {
        s.push('\n');
    }
    for (name, alt) in [
        (
            "fig3_energy_heatmap",
            "Fig. 3: energy over r2 and swing time",
        ),
        (
            "fig3c_positive_work_heatmap",
            "positive work over r2 and swing time",
        ),
        ("fig3b_energy_vs_swing_time", "energy against swing time"),
        ("fig4a_swing_time", "Fig. 4a: T against r2"),
    ] {
        let _ = writeln!(
            s,
            "![{alt}]({})\n",
            figs.join(format!("{name}.png")).display()
        );
    }
    for st in &st.sticks {
        let name = stick_name(st.r2);
        let _ = writeln!(
            s,
            "![Fig. 4b: r2 = {}]({})\n",
            st.r2,
            figs.join(format!("{name}.png")).display()
        );
    }
    s
}
