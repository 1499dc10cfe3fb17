//! The Monte Carlo compared draw by draw with the plain MPC (`summary.md`, "Per draw against
//! `mpc`"): for every other controller and family, the runs caught, the draws it ends more than
//! [`PER_DRAW_NOISE_M`] farther from / closer to the bar than `mpc` on the same draw, and the
//! draws `mpc` misses that it catches. An average hides a controller that makes some draws worse
//! and others better; the same draw run by both does not.

use super::BenchRow;
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// A draw ends "worse" / "better" than the plain MPC when its final distance from the bar is more
/// than this farther / closer, m (the run-to-run spread of the measure, not a model of it).
pub const PER_DRAW_NOISE_M: f64 = 0.002;

/// The controller every other one is compared with.
const BASE: &str = "mpc";

/// One controller on one family, compared with the plain MPC draw by draw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct PerDraw {
    /// Draws run by both.
    pub draws: usize,
    /// Of them, caught by the plain MPC.
    pub base_caught: usize,
    /// Caught by the controller.
    pub caught: usize,
    /// Ended more than [`PER_DRAW_NOISE_M`] farther from the bar than the plain MPC.
    pub worse: usize,
    /// Ended more than [`PER_DRAW_NOISE_M`] closer to the bar than the plain MPC.
    pub better: usize,
    /// Missed by the plain MPC, caught by the controller.
    pub rescued: usize,
    /// Caught by the plain MPC, missed by the controller.
    pub lost: usize,
}

/// Per (controller, family), in the order the rows give them: the Monte Carlo rows (family names
/// from `families`) of every controller but `mpc`, matched with `mpc`'s row of the same family
/// and seed. Empty when `mpc` did not run.
pub fn per_draw(rows: &[BenchRow], families: &[&str]) -> Vec<(String, String, PerDraw)> {
    let is_mc = |r: &BenchRow| families.contains(&r.disturbance.as_str());
    let base: BTreeMap<(&str, u64), &BenchRow> = rows
        .iter()
        .filter(|r| r.controller == BASE && is_mc(r))
        .map(|r| ((r.disturbance.as_str(), r.seed), r))
        .collect();
    let mut out: Vec<(String, String, PerDraw)> = Vec::new();
    for r in rows.iter().filter(|r| r.controller != BASE && is_mc(r)) {
        let Some(b) = base.get(&(r.disturbance.as_str(), r.seed)) else {
            continue;
        };
        let i = match out
            .iter()
            .position(|(c, f, _)| *c == r.controller && *f == r.disturbance)
        {
            Some(i) => i,
            None => {
                out.push((
                    r.controller.clone(),
                    r.disturbance.clone(),
                    PerDraw::default(),
                ));
                out.len() - 1
            }
        };
        let p = &mut out[i].2;
        p.draws += 1;
        p.base_caught += usize::from(b.success);
        p.caught += usize::from(r.success);
        p.worse += usize::from(r.final_error_m > b.final_error_m + PER_DRAW_NOISE_M);
        p.better += usize::from(r.final_error_m < b.final_error_m - PER_DRAW_NOISE_M);
        p.rescued += usize::from(!b.success && r.success);
        p.lost += usize::from(b.success && !r.success);
    }
    out
}

/// The "Per draw against `mpc`" section of `summary.md` (empty when there is nothing to compare).
pub fn per_draw_md(rows: &[BenchRow], families: &[&str]) -> String {
    let t = per_draw(rows, families);
    if t.is_empty() {
        return String::new();
    }
    let mut s = format!(
        "\n## Per draw against `mpc`\n\nEvery Monte Carlo draw run by `mpc` and another controller: \
         the runs each catches, the draws the other ends more than {} mm farther from (worse) or \
         closer to (better) the bar than `mpc` on the same draw, the draws `mpc` misses that it \
         catches (rescued) and those `mpc` catches that it misses (lost).\n\n\
         | controller | family | draws | `mpc` caught | caught | worse | better | rescued | lost |\n\
         |---|---|---|---|---|---|---|---|---|\n",
        PER_DRAW_NOISE_M * 1e3
    );
    let mut total: BTreeMap<&str, PerDraw> = BTreeMap::new();
    for (c, f, p) in &t {
        write_row(&mut s, c, f, p);
        *total.entry(c.as_str()).or_default() += *p;
    }
    for (c, p) in &total {
        write_row(&mut s, c, "all", p);
    }
    s
}

/// One row of the per-draw table: controller `c`, family `f`.
fn write_row(s: &mut String, c: &str, f: &str, p: &PerDraw) {
    let _ = writeln!(
        s,
        "| {c} | {f} | {} | {} | {} | {} | {} | {} of {} | {} |",
        p.draws,
        p.base_caught,
        p.caught,
        p.worse,
        p.better,
        p.rescued,
        p.draws - p.base_caught,
        p.lost
    );
}

impl std::ops::AddAssign for PerDraw {
    fn add_assign(&mut self, o: PerDraw) {
        self.draws += o.draws;
        self.base_caught += o.base_caught;
        self.caught += o.caught;
        self.worse += o.worse;
        self.better += o.better;
        self.rescued += o.rescued;
        self.lost += o.lost;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(controller: &str, family: &str, seed: u64, err_mm: f64) -> BenchRow {
        BenchRow {
            controller: controller.into(),
            disturbance: family.into(),
            level: 0.0,
            seed,
            success: err_mm <= 20.0,
            capture_t_s: None,
            final_error_m: err_mm * 1e-3,
            energy_j: 0.0,
            peak_torque_nm: 0.0,
            smoothness_nm: 0.0,
            ball_kg: 0.0,
            ball_t_s: None,
            contact_s: None,
            replans: 0,
            replans_adopted: 0,
            replan_latency_s: 0.0,
            replan_iterations: 0,
            contact_last_s: None,
            contact_impulse_n_s: 0.0,
            replan_t_s: vec![],
            replan_miss_m: vec![],
        }
    }

    #[test]
    fn draws_are_matched_by_family_and_seed() {
        let rows = vec![
            row("mpc", "monte_carlo", 1, 5.0),
            row("mpc", "monte_carlo", 2, 30.0),
            row("mpc", "monte_carlo", 3, 10.0),
            row("mpc", "mc_push", 1, 1.0),
            // a sweep row is no draw
            row("mpc", "mass", 1, 1.0),
            row("mpc+replan", "mass", 1, 50.0),
            // worse by 4 mm; rescued; within the noise
            row("mpc+replan", "monte_carlo", 1, 9.0),
            row("mpc+replan", "monte_carlo", 2, 3.0),
            row("mpc+replan", "monte_carlo", 3, 11.5),
            // same seed, other family: compared with mpc_push's seed 1, lost
            row("mpc+replan", "mc_push", 1, 25.0),
            // no mpc row for it
            row("mpc+replan", "mc_push", 9, 1.0),
        ];
        let t = per_draw(&rows, &["monte_carlo", "mc_push"]);
        assert_eq!(t.len(), 2, "{t:?}");
        let mc = &t[0];
        assert_eq!(
            (mc.0.as_str(), mc.1.as_str()),
            ("mpc+replan", "monte_carlo")
        );
        let expect = PerDraw {
            draws: 3,
            base_caught: 2,
            caught: 3,
            worse: 1,
            better: 1,
            rescued: 1,
            lost: 0,
        };
        assert_eq!(mc.2, expect);
        let push = &t[1];
        assert_eq!(push.1, "mc_push");
        assert_eq!((push.2.draws, push.2.worse, push.2.lost), (1, 1, 1));
        let md = per_draw_md(&rows, &["monte_carlo", "mc_push"]);
        assert!(
            md.contains("| mpc+replan | all | 4 | 3 | 3 | 2 | 1 | 1 of 1 | 1 |"),
            "{md}"
        );
        assert!(per_draw_md(&rows[5..], &["monte_carlo"]).is_empty());
    }
}
