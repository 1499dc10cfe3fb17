//! Which placements of the fixed placement scan (`placement_scan.rs`, seeds 1..=40) can be planned
//! at all: every placement the default planner does not plan clear within the scan's time limit is
//! searched hard, with a large budget of its own, from many more seeds than the planner's race
//! (every detour seed, C-space routes to more goal poses and more routes per goal), at longer swing
//! times (a swing time free in `[T, 2 T]` started at `2 T`, and a fixed `f T` for several factors
//! `f` up to 2; the task's swing time is `"auto"`; a C-space route is timed over the swing time it
//! starts at), with more iterations and with the continuation on the torque limits. Each solve is coarse to fine (90 ms knots, then the task's 30 ms knots warm from it). The
//! first plan that converges with its 1 ms trajectory clear of every obstacle by the margin (less
//! the tolerance) ends the search of a placement and is recorded with what it came from (the seed's
//! class, goal and route, the swing time, the iterations). A placement the search does not plan
//! is, on this evidence, probably infeasible (a local solver from many seeds, not a proof).
//!
//! Ignored (about half an hour):
//! `cargo test --release -p brachia --test placement_oracle -- --ignored --nocapture`.
//! `BRACHIA_ORACLE_SEEDS=5,7,...` takes those seeds only, `BRACHIA_ORACLE_SKIP_DEFAULT=1` searches
//! them without the default planner's run first, `BRACHIA_ORACLE_BUDGET_S` sets the budget per
//! placement (default 240 s), `BRACHIA_ORACLE_CSPACE_ONLY=1` leaves the detour seeds out,
//! `BRACHIA_ORACLE_LONGER_ONLY=1` tries the C-space seeds at the longer swing times only, without
//! the torque continuation. Units: m, s.

mod common;

use brachia::model::Robot;
use brachia::planning::{PlannerSettings, SwingTask};
use common::oracle::search;
use common::placement::{free_swing, keeps_margin, plan_placement, swing_placement};

/// The scan's wall-time limit of the default planner's call, s.
const SCAN_LIMIT_S: f64 = 30.0;
#[test]
#[ignore = "about half an hour: the oracle of the fixed placement scan"]
fn the_oracle_of_the_fixed_placement_scan() {
    let robot = Robot::paper();
    let free = free_swing(&robot, &SwingTask::paper(), "paper", SCAN_LIMIT_S);
    let budget: f64 = std::env::var("BRACHIA_ORACLE_BUDGET_S")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(240.0);
    let only: Option<Vec<u64>> = std::env::var("BRACHIA_ORACLE_SEEDS")
        .ok()
        .map(|v| v.split(',').filter_map(|x| x.trim().parse().ok()).collect());
    let s = PlannerSettings::default();
    let (mut by_default, mut by_oracle, mut neither) = (vec![], vec![], vec![]);
    for seed in only.clone().unwrap_or_else(|| (1..=40).collect()) {
        let Some(pl) = swing_placement(&robot, &free, seed) else {
            continue;
        };
        if std::env::var_os("BRACHIA_ORACLE_SKIP_DEFAULT").is_none() {
            let m = plan_placement(&robot, &SwingTask::paper(), &s, &pl, SCAN_LIMIT_S);
            let p = m.plan.unwrap();
            if p.converged() && keeps_margin(&s, m.min_clearance_m) {
                eprintln!(
                    "| {seed} | {} | default planner: clear in {:.2} s ({:?}) |",
                    pl.what,
                    m.time_s,
                    p.guess.as_ref().map(|g| g.strategy)
                );
                by_default.push(seed);
                continue;
            }
            eprintln!(
                "| {seed} | {} | default planner: failed in {:.2} s: {} |",
                pl.what,
                m.time_s,
                p.failure_message().unwrap_or_default()
            );
        }
        match search(&robot, &SwingTask::paper(), &free, &pl, budget) {
            Some(how) => {
                eprintln!("| {seed} | {} | oracle: clear, {how} |", pl.what);
                by_oracle.push(seed);
            }
            None => {
                eprintln!("| {seed} | {} | oracle: no clear plan |", pl.what);
                neither.push(seed);
            }
        }
    }
    eprintln!(
        "default planner clear: {} {by_default:?}; oracle clear: {} {by_oracle:?}; neither: {} \
         {neither:?}",
        by_default.len(),
        by_oracle.len(),
        neither.len()
    );
}
