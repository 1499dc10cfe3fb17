//! What the online mass estimate does on each plant, one kind of disturbance at a time
//! (docs/estimation.md, "On the rapier plant").
//!
//! The tracking scenario's swing (`scenarios/tracking.toml`) is tracked by the MPC on the nominal
//! robot while the joint filter watches (passive: its estimate is not used), on the model plant
//! (RK4) and on the rapier plant, under one disturbance each: none, sensor noise, a measurement or an
//! actuation delay, torque noise, a ball on the hand's path, a geometry mismatch, a coherent mass
//! factor. Printed per case: the worst base parameter's error relative to the plant's own base
//! parameters at 25, 50, 75 and 100 % of the swing, the filter's mean normalised innovation squared
//! (8 degrees of freedom for the 4-link robot when consistent) and its rejected measurements, then
//! the final distance to the bar of the passive run, of the MPC fed the estimate (`Adaptive<Mpc>`)
//! and of the default estimate settings' `Adaptive<Replanning<Mpc>>` against `Replanning<Mpc>`.
//!
//! `estimate_probe [CASE ...]` runs the named cases (default all); `BRACHIA_PROBE_PLANTS` `model`,
//! `rapier` or both (the default); `BRACHIA_PROBE_ACTIVE=0` skips the runs that use the estimate.
//! `BRACHIA_PROBE_EST` overrides the estimate settings with the inside of a TOML inline table, e.g.
//! `BRACHIA_PROBE_EST='use_max_rel_std = 1e3, use_max_nis_ratio = 1e3, use_min_sigma = 0.0,
//! use_min_rel_change = 0.0'` (every estimate handed over from the first sample).
//!
//! Units: rad, rad/s, m, s, kg.

use brachia::control::base_params::base_params;
use brachia::control::{Adaptive, ParamEstimator, ParamEstimatorSettings, Replanning};
use brachia::sim::{ControlInfo, Controller, Disturbances};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use brachia_experiments::benchmark::{replan_settings, simulate};
use brachia_experiments::scenario::{LoadedScenario, PlantKind};
use brachia_experiments::success::capture;
use brachia_experiments::{run_plan, Scenario};
use brachia_rapier::{Ball, Obstacle};
use rayon::prelude::*;
use std::path::Path;
use std::sync::Arc;

/// The MPC on the nominal robot with a filter watching: the estimate is recorded, never used.
struct Passive {
    inner: Box<dyn Controller>,
    est: ParamEstimator,
    truth: Vec<f64>,
    tau_last: Vec<f64>,
    have_tau: bool,
    t_end: f64,
    /// Worst relative error at 25, 50, 75, 100 % of the swing.
    at: [f64; 4],
    nis_sum: f64,
    nis_n: usize,
    /// First time the largest relative standard deviation is at most 5, 3, 2 %, and the worst
    /// error then.
    below: [(f64, f64); 3],
}

impl Passive {
    fn worst(&self) -> f64 {
        self.truth
            .iter()
            .zip(self.est.theta())
            .map(|(a, b)| ((a - b) / a).abs())
            .fold(0.0, f64::max)
    }
}

impl Controller for Passive {
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        if self.have_tau {
            self.est.observe(t, x, &self.tau_last);
            if let Some(nis) = self.est.joint_filter().map(|f| f.last_nis()) {
                if nis.is_finite() {
                    self.nis_sum += nis;
                    self.nis_n += 1;
                }
            }
        }
        for (k, frac) in [0.25, 0.5, 0.75].iter().enumerate() {
            if t <= frac * self.t_end {
                self.at[k] = self.worst();
            }
        }
        self.at[3] = self.worst();
        let rel = self.est.max_rel_std();
        for (k, lim) in [0.05, 0.03, 0.02].iter().enumerate() {
            if rel <= *lim && self.below[k].0.is_nan() {
                self.below[k] = (t, self.worst());
            }
        }
        let info = self.inner.control(t, x, tau);
        self.tau_last.copy_from_slice(tau);
        self.have_tau = true;
        info
    }
    fn name(&self) -> &'static str {
        "passive"
    }
}

struct Case {
    name: &'static str,
    dist: Disturbances,
    ball: bool,
}

/// A case without a ball.
fn case(name: &'static str, dist: Disturbances) -> Case {
    Case {
        name,
        dist,
        ball: false,
    }
}

fn cases() -> Vec<Case> {
    let noise = |d: Disturbances| Disturbances {
        noise_q_std: 0.0015,
        noise_qd_std: 0.015,
        seed: 11,
        ..d
    };
    let d = Disturbances::default;
    let geometry = || Disturbances {
        length_scale: vec![1.02, 0.98, 1.01, 0.99],
        com_scale: vec![1.05, 0.95, 1.08, 0.93],
        inertia_scale: vec![1.1, 0.9, 1.15, 0.85],
        ..d()
    };
    // a coherent factor on every link's mass and inertia
    let mass = |f: f64| Disturbances {
        mass_scale: vec![f; 4],
        inertia_scale: vec![f; 4],
        ..d()
    };
    vec![
        case("none", d()),
        case("noise", noise(d())),
        case(
            "meas_delay_3ms",
            Disturbances {
                measurement_delay_s: 3e-3,
                ..d()
            },
        ),
        case(
            "act_delay_3ms",
            Disturbances {
                actuation_delay_s: 3e-3,
                ..d()
            },
        ),
        case(
            "torque_noise",
            Disturbances {
                torque_noise_std: 0.1,
                seed: 5,
                ..d()
            },
        ),
        case(
            "torque_noise_n",
            noise(Disturbances {
                torque_noise_std: 0.1,
                ..d()
            }),
        ),
        case(
            "meas_delay_n",
            noise(Disturbances {
                measurement_delay_s: 3e-3,
                ..d()
            }),
        ),
        Case {
            name: "ball",
            dist: d(),
            ball: true,
        },
        case("geometry", geometry()),
        case("geometry_n", noise(geometry())),
        case("mass_1.15", mass(1.15)),
        case("mass_1.15_noise", noise(mass(1.15))),
        case("mass_0.85_noise", noise(mass(0.85))),
    ]
}

fn settings() -> ParamEstimatorSettings {
    match std::env::var("BRACHIA_PROBE_EST") {
        Ok(v) if !v.trim().is_empty() => {
            #[derive(serde::Deserialize)]
            struct Wrap {
                e: ParamEstimatorSettings,
            }
            let w: Wrap = toml::from_str(&format!("e = {{ {v} }}")).expect(
                "BRACHIA_PROBE_EST: the inside of a TOML inline table of estimate settings",
            );
            w.e
        }
        _ => ParamEstimatorSettings::default(),
    }
}

/// Run `ctrl` on `plant` (the model or the rapier plant, as the benchmark's runs:
/// [`simulate`]) under `case`: the hand's distance to the bar at the capture, mm, or 1000 + the
/// miss at T, mm.
fn run(
    ls: &LoadedScenario,
    reference: &Arc<Trajectory>,
    probot: &Robot,
    case: &Case,
    rapier: bool,
    ctrl: &mut dyn Controller,
) -> f64 {
    let sc = &ls.scenario;
    let mut balls = vec![];
    if case.ball && rapier {
        let (b, _) = Ball::on_path(
            reference,
            &ls.robot,
            0.5 * reference.duration(),
            0.3,
            0.05,
            0.3,
        );
        balls.push(Obstacle::Ball(b));
    }
    let plant = if rapier {
        PlantKind::Rapier
    } else {
        PlantKind::Model
    };
    let (log, _) = simulate(ls, reference, probot, plant, &case.dist, &balls, ctrl).unwrap();
    let c = capture(probot, &log, reference.duration(), sc.task.target);
    if c.reaches_bar {
        1e3 * c.bar_error_m
    } else {
        1e3 * c.bar_error_m + 1000.0
    }
}

/// The re-plans: trigger time @ predicted miss [continue / re-plan, mm], `x` not adopted, `e`
/// planned on the estimate.
fn describe(ev: &[brachia::control::ReplanEvent]) -> String {
    ev.iter()
        .map(|e| {
            format!(
                "{:.3}@{:.1}[{:.1}/{:.1}]{}{}",
                e.t_trigger_s,
                1e3 * e.predicted_miss_m,
                1e3 * e.predicted_continue_m.unwrap_or(f64::NAN),
                1e3 * e.predicted_replan_m.unwrap_or(f64::NAN),
                if e.adopted { "" } else { "x" },
                if e.planned_on_estimate { "e" } else { "" }
            )
        })
        .collect::<Vec<_>>()
        .join(" ")
}

fn mpc(ls: &LoadedScenario, r: &Arc<Trajectory>) -> Box<dyn Controller> {
    let s = ls.scenario.tracking.mpc.clone();
    Box::new(brachia::control::Mpc::new(ls.robot.clone(), Arc::clone(r), s).unwrap())
}

fn replanning(ls: &LoadedScenario, r: &Arc<Trajectory>) -> Replanning<Box<dyn Controller>> {
    let sc = &ls.scenario;
    Replanning::build(
        mpc(ls, r),
        ls.robot.clone(),
        &sc.task,
        &sc.planner,
        &sc.solver,
        Arc::clone(r),
        replan_settings(ls),
    )
    .unwrap()
}

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let ls = Scenario::load(&root.join("scenarios/tracking.toml")).unwrap();
    let plan = run_plan(&ls).unwrap();
    let reference = Arc::new(plan.plan.trajectory.clone());
    let names: Vec<String> = std::env::args().skip(1).collect();
    let plants = std::env::var("BRACHIA_PROBE_PLANTS").unwrap_or_else(|_| "model,rapier".into());
    let active = std::env::var("BRACHIA_PROBE_ACTIVE").as_deref() != Ok("0");
    let est = settings();
    let jobs: Vec<(Case, bool)> = cases()
        .into_iter()
        .filter(|c| names.is_empty() || names.iter().any(|n| n == c.name))
        .flat_map(|c| {
            plants.split(',').map(move |p| {
                (
                    Case {
                        name: c.name,
                        dist: c.dist.clone(),
                        ball: c.ball,
                    },
                    p == "rapier",
                )
            })
        })
        .collect();
    println!(
        "case, plant, worst base-parameter error % at 25/50/75/100 % of T, mean NIS, rejected, \
         final bar error mm: passive, mpc+estimate, mpc+replan, mpc+estimate+replan"
    );
    let lines: Vec<String> = jobs
        .par_iter()
        .map(|(case, rapier)| {
            let probot =
                Robot::from_params(case.dist.plant_params(ls.robot.params()), "probe plant").unwrap();
            let mut truth = vec![0.0; 2 * probot.n()];
            base_params(&probot, &mut truth);
            let mut p = Passive {
                inner: mpc(&ls, &reference),
                est: ParamEstimator::new(ls.robot.clone(), est).unwrap(),
                truth,
                tau_last: vec![0.0; ls.robot.n() - 1],
                have_tau: false,
                t_end: reference.duration(),
                at: [0.0; 4],
                nis_sum: 0.0,
                nis_n: 0,
                below: [(f64::NAN, f64::NAN); 3],
            };
            let e_passive = run(&ls, &reference, &probot, case, *rapier, &mut p);
            let (mut e_est, mut e_rp, mut e_est_rp) = (f64::NAN, f64::NAN, f64::NAN);
            let mut events = String::new();
            if active {
                let mut a = Adaptive::new(mpc(&ls, &reference), ls.robot.clone(), est).unwrap();
                e_est = run(&ls, &reference, &probot, case, *rapier, &mut a);
                let mut rp = replanning(&ls, &reference);
                e_rp = run(&ls, &reference, &probot, case, *rapier, &mut rp);
                let mut a = Adaptive::new(replanning(&ls, &reference), ls.robot.clone(), est).unwrap();
                e_est_rp = run(&ls, &reference, &probot, case, *rapier, &mut a);
                events = format!(
                    "\n    mpc+replan: {}\n    mpc+estimate+replan: {} (model updates {}, used from {:?} s)",
                    describe(rp.events()),
                    describe(a.inner().events()),
                    a.model_updates(),
                    a.used_from()
                );
            }
            let at: String = p.at.iter().map(|e| format!(" {:6.1}", 100.0 * e)).collect();
            let below: Vec<String> = p
                .below
                .iter()
                .map(|(t, e)| format!("{t:.3} s ({:.1} %)", 100.0 * e))
                .collect();
            format!(
                "{:<16} {:<6}{at}   nis {:8.2}  rej {:4}   {:7.2} {:7.2} {:7.2} {:7.2}\n    std <= \
                 5/3/2 % from {}, NIS ratio at the end {:.3}{events}",
                case.name,
                if *rapier { "rapier" } else { "model" },
                p.nis_sum / p.nis_n.max(1) as f64,
                p.est.report().rejected,
                e_passive,
                e_est,
                e_rp,
                e_est_rp,
                below.join(", "),
                p.est.nis_ratio()
            )
        })
        .collect();
    for l in lines {
        println!("{l}");
    }
}
