//! Which swing times the two-link hook robot (params/two-link-hook.toml) can reach the next bar in, with
//! its torque limit dropped: dynamic programming over the reduced model (the elbow angle a kinematic
//! input within +-2.9 rad and +-15 rad/s, the grip's angle free; `brachia_tools::swing_dp`).
//!
//! For the rear hand on the previous bar 0.34 m behind the grip (and for a straight hang), swinging to
//! the bar 0.34 m ahead, it prints the least terminal miss (the hand's distance to the bar and the
//! momentum left, combined as in `swing_dp`) at every swing time of the table, at each grid resolution,
//! and the miss of the motion each resolution's values lead to (attained by the reduced system).
//!
//! ```text
//! cargo run --release -p brachia-tools --bin hook_swing_dp            # resolutions 1-3, a few minutes
//! cargo run --release -p brachia-tools --bin hook_swing_dp -- 1 2     # only the given resolutions
//! cargo run --release -p brachia-tools --bin hook_swing_dp -- free     # q1 free, not in [-pi, 0]
//! cargo run --release -p brachia-tools --bin hook_swing_dp -- 2 csv=rollout.csv t=1.0
//!     # also write the motion of swing time 1.0 s from resolution 2 (t s, q1, H, q2, u)
//! cargo run --release -p brachia-tools --bin hook_swing_dp -- 2 plan t=1.16
//!     # also plan the real robot at 1.16 s from that motion as the guess: within 3 N m, and within
//!     # 100 N m then lowered warm to the least limit that still converges
//!     # (with `free`, the planner's q1 bound widened to +-4 pi)
//! ```
//! Units: m, s, rad, kg m^2/s.
use brachia::model::ik_from_seed;
use brachia::planning::{
    plan_with_guess, NlpSettings, Plan, PlannerSettings, SwingTask, SwingTime,
};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use brachia_tools::reduced_two_link::ReducedTwoLink;
use brachia_tools::swing_dp::{DpSettings, Rollout, ValueHistory};
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

/// A grid: nodes in q1, H, q2, elbow rates per step, time step (s).
type Resolution = (usize, usize, usize, usize, f64);

/// Resolution `r` (1 coarsest) over q1's range (`below`: half a turn, else a whole one).
fn resolution(r: &str, below: bool) -> Result<Resolution, Box<dyn std::error::Error>> {
    let n1 = |k: usize| if below { k * 5 / 8 } else { k };
    Ok(match r {
        "1" => (n1(96), 48, 48, 13, 0.025),
        "2" => (n1(160), 80, 80, 21, 0.025),
        "3" => (n1(240), 120, 120, 31, 0.025),
        _ => {
            // N1xNHxN2xNUxDT
            let p: Vec<&str> = r.split('x').collect();
            if p.len() != 5 {
                return Err(format!("a resolution is 1, 2, 3 or N1xNHxN2xNUxDT, not {r}").into());
            }
            (
                p[0].parse()?,
                p[1].parse()?,
                p[2].parse()?,
                p[3].parse()?,
                p[4].parse()?,
            )
        }
    })
}

fn settings((n_q1, n_h, n_q2, n_u, dt): Resolution, q1_range: Option<[f64; 2]>) -> DpSettings {
    DpSettings {
        n_q1,
        q1_range,
        n_h,
        n_q2,
        h_max: 1.5,
        q2_max: 2.9,
        u_max: 15.0,
        n_u,
        dt,
        steps: (1.5 / dt).round() as usize,
        substeps: 2,
        bar: [0.34, 0.0],
        drift_s: 0.1,
        keep_history: true,
    }
}

/// Plan the real robot at `t` s from the reduced motion `ro` as the guess, within 3 N m and 100 N m.
fn plan_from(
    robot: &Robot,
    model: &ReducedTwoLink,
    q0: &[f64],
    ro: &Rollout,
    t: f64,
    q1_free: bool,
) -> Result<(), Box<dyn std::error::Error>> {
    let mut guess = Trajectory::new(2);
    for (j, x) in ro.x.iter().enumerate() {
        let u = ro.u.get(j).or(ro.u.last()).copied().unwrap_or(0.0);
        let q1d = (x[1] - model.m12(x[2]) * u) / model.m11(x[2]);
        guess.push(ro.t[j], &[x[0], x[2]], &[q1d, u], &[0.0]);
    }
    let task = SwingTask {
        q0: q0.to_vec(),
        qd0: vec![],
        target: [0.34, 0.0],
        obstacles: vec![],
    };
    let solve = |limit: f64, guess: &Trajectory| -> Result<Plan, Box<dyn std::error::Error>> {
        let mut p = robot.params().clone();
        p.actuators.tau_min = vec![-limit];
        p.actuators.tau_max = vec![limit];
        let r = Robot::from_params(p, "two-link-hook")?;
        let mut s = PlannerSettings {
            swing_time: SwingTime::Seconds(t),
            swing_time_search: false,
            ..Default::default()
        };
        if q1_free {
            // the motion may turn link 1 over the bar: q1 within two turns
            s.bounds.q1 = [-4.0 * PI, 4.0 * PI];
        }
        let t0 = Instant::now();
        let pl = plan_with_guess(&r, &task, &s, &NlpSettings::default(), Some(guess))?;
        println!(
            "plan at {t} s within {limit:.3} N m: {:?}, {} iterations, peak |tau| {:.3} N m, {:.1} s",
            pl.status,
            pl.iterations,
            peak(&pl),
            t0.elapsed().as_secs_f64()
        );
        Ok(pl)
    };
    solve(3.0, &guess)?;
    // from the plan within 100 N m, the limit lowered warm to 97 % of the last peak while plans converge
    let mut last = solve(100.0, &guess)?;
    for _ in 0..40 {
        if !last.converged() {
            break;
        }
        let next = solve(0.97 * peak(&last), &last.points)?;
        if !next.converged() {
            break;
        }
        last = next;
    }
    Ok(())
}

fn peak(p: &Plan) -> f64 {
    p.points.tau.iter().fold(0.0f64, |a, b| a.max(b.abs()))
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg").unwrap_or_default()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut res = vec![];
    let below = Some([-PI, 0.0]);
    let (mut csv, mut csv_t, mut plan, mut q1_range) = (None, 1.0, false, below);
    for a in std::env::args().skip(1) {
        if a == "plan" {
            plan = true;
        } else if a == "free" {
            q1_range = None;
        } else if let Some(p) = a.strip_prefix("csv=") {
            csv = Some(p.to_string());
        } else if let Some(t) = a.strip_prefix("t=") {
            csv_t = t.parse()?;
        } else {
            res.push(a);
        }
    }
    if res.is_empty() {
        res = vec!["1".into(), "2".into(), "3".into()];
    }
    let robot = brachia_tools::hook_robot()?;
    let model = ReducedTwoLink::new(&robot)?;
    let rear = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).ok_or("no rear-hand pose")?;
    let starts = [[rear[0], 0.0, rear[1]], [-FRAC_PI_2, 0.0, 0.0]];
    println!(
        "rear-hand start q = [{:.4}, {:.4}]; |dV/dq1| <= {:.3} N m",
        rear[0],
        rear[1],
        model.max_dv_dq1()
    );
    let times: Vec<f64> = (0..=32).map(|k| 0.70 + 0.025 * k as f64).collect();
    let mut cols = vec![];
    for r in &res {
        let s = settings(resolution(r, q1_range.is_some())?, q1_range);
        let t0 = Instant::now();
        let load0 = load();
        let v = ValueHistory::solve(&model, &s, &starts);
        let el = t0.elapsed().as_secs_f64();
        println!(
            "resolution {r}: {} x {} x {} nodes, {} rates, dt {} s, {} steps: {el:.1} s (load before {} after {}); lambda {:.3} m per kg m^2/s",
            s.n_q1, s.n_h, s.n_q2, s.n_u, s.dt, s.steps, load0.trim(), load().trim(), v.lambda()
        );
        let k_of = |t: f64| (t / s.dt).round() as usize;
        let rolls: Vec<[Option<Rollout>; 2]> = times
            .iter()
            .map(|&t| [0, 1].map(|i| v.rollout(starts[i], k_of(t), 4 * s.n_u)))
            .collect();
        if let Some(p) = &csv {
            if let Some(ro) = v.rollout(starts[0], k_of(csv_t), 4 * s.n_u) {
                let mut out = String::from("# t_s,q1_rad,H_kgm2s,q2_rad,u_rads\n");
                for (j, x) in ro.x.iter().enumerate() {
                    let u = ro.u.get(j).copied().unwrap_or(0.0);
                    out += &format!("{},{},{},{},{}\n", ro.t[j], x[0], x[1], x[2], u);
                }
                std::fs::write(p, out)?;
            }
        }
        if plan {
            if let Some(ro) = v.rollout(starts[0], k_of(csv_t), 4 * s.n_u) {
                plan_from(&robot, &model, &rear, &ro, csv_t, q1_range.is_none())?;
            }
        }
        let vals: Vec<[f64; 2]> = times
            .iter()
            .map(|&t| [v.at_start(0)[k_of(t)], v.at_start(1)[k_of(t)]])
            .collect();
        cols.push((r.clone(), vals, rolls));
    }
    println!();
    print!("| T s |");
    for (r, _, _) in &cols {
        print!(" rear V{r} m | rear motion{r} m (hand m, abs H) |");
    }
    for (r, _, _) in &cols {
        print!(" hang V{r} m | hang motion{r} m |");
    }
    println!();
    for (i, t) in times.iter().enumerate() {
        print!("| {t:.3} |");
        for (_, vals, rolls) in &cols {
            let ro = rolls[i][0].as_ref().map(|r| r.end);
            let m = ro.map_or("-".into(), |e| {
                format!("{:.4} ({:.4}, {:.4})", e.miss, e.hand_m, e.momentum)
            });
            print!(" {:.4} | {m} |", vals[i][0]);
        }
        for (_, vals, rolls) in &cols {
            let ro = rolls[i][1].as_ref().map(|r| r.end);
            let m = ro.map_or("-".into(), |e| format!("{:.4}", e.miss));
            print!(" {:.4} | {m} |", vals[i][1]);
        }
        println!();
    }
    for (r, _, rolls) in &cols {
        let hmax = rolls
            .iter()
            .flatten()
            .flatten()
            .flat_map(|ro| ro.x.iter().map(|x| x[1].abs()))
            .fold(0.0f64, f64::max);
        println!("resolution {r}: largest |H| along the motions {hmax:.3}");
    }
    Ok(())
}
