//! A proof that the two-link hook robot (params/two-link-hook.toml) cannot reach the bar 0.34 m ahead
//! at rest at some swing times, whatever its elbow torque: a sound over-approximation of the reduced
//! model's reachable set (`brachia_tools::reach_box`; the elbow angle a kinematic input within
//! +-2.9 rad and +-15 rad/s, link 1 below the bar at the step times), from the rear hand on the
//! previous bar 0.34 m behind the grip (or, with `hang`, a straight hang), at rest.
//!
//! At each swing time 0.80, 0.85, ..., 1.30 s it prints the margin (no reachable state has the hand
//! within this distance of the bar with `lambda |H|` below it; the target set is the margin's 1 mm),
//! the least hand distance at any momentum, whether the swing time is proven out of reach, the occupied
//! cells and the time taken.
//!
//! ```text
//! cargo run --release -p brachia-tools --bin hook_reach                  # forward, the default grid
//! cargo run --release -p brachia-tools --bin hook_reach -- mid           # meet in the middle
//! cargo run --release -p brachia-tools --bin hook_reach -- 0.005x77x0.02x0.01x8
//!     # DT (s) x q2 cells x z cell (rad) x H cell (kg m^2/s) x target split
//! cargo run --release -p brachia-tools --bin hook_reach -- hang          # from a straight hang
//! cargo run --release -p brachia-tools --bin hook_reach -- t=1.0,1.05    # only these swing times
//! cargo run --release -p brachia-tools --bin hook_reach -- sweep t=0.9 refine=116x0.005x0.0025
//!     # forward-backward sweeps, then on finer q2 x z x H cells pruned by them (passes=N a grid;
//!     # N2xDZxDHxDT also steps the finer grid by DT, a whole fraction of the coarser one's)
//! ```
//! Units: m, s, rad, kg m^2/s.
use brachia::model::ik_from_seed;
use brachia_tools::reach_box::{meets_reversed, ReachBox, ReachError, ReachSettings, Snapshot};
use brachia_tools::reach_interval::Iv;
use brachia_tools::reach_model::ReachModel;
use brachia_tools::reach_sweep::{sweep, Direction, SweepSettings};
use brachia_tools::reduced_two_link::ReducedTwoLink;
use brachia_tools::swing_dp::lambda;
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

/// The target set: the hand within this distance of the bar and `lambda |H|` below it, m.
const EPS: f64 = 0.001;

/// Splits of a swing time tried by `mid`: the half, and up to this many steps either side.
const SPLITS: usize = 3;

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .trim()
        .to_string()
}

/// The process's peak resident memory so far, GB (0 where the system does not say).
fn peak_gb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap_or_default()
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse::<f64>().ok())
        .map_or(0.0, |kb| kb / 1e6)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut grid, mut hang, mut mid) = ("0.01x58x0.01x0.005x8".to_string(), false, false);
    let (mut sweeps, mut passes, mut refine) = (false, 6, vec![]);
    let mut times: Vec<f64> = (0..=10).map(|k| 0.80 + 0.05 * k as f64).collect();
    for a in std::env::args().skip(1) {
        if a == "hang" {
            hang = true;
        } else if a == "mid" {
            mid = true;
        } else if a == "sweep" {
            sweeps = true;
        } else if let Some(r) = a.strip_prefix("refine=") {
            // finer grids, each pruned by the sweeps of the one before: N2xDZxDH[xDT],...
            for g in r.split(',') {
                let v: Vec<&str> = g.split('x').collect();
                if v.len() != 3 && v.len() != 4 {
                    return Err(format!("refine=N2xDZxDH[xDT],..., not {g}").into());
                }
                refine.push((
                    v[0].parse::<usize>()?,
                    v[1].parse::<f64>()?,
                    v[2].parse::<f64>()?,
                    v.get(3).map(|d| d.parse::<f64>()).transpose()?,
                ));
            }
        } else if let Some(n) = a.strip_prefix("passes=") {
            passes = n.parse()?;
        } else if let Some(t) = a.strip_prefix("t=") {
            times = t.split(',').map(str::parse).collect::<Result<_, _>>()?;
        } else {
            grid = a;
        }
    }
    let p: Vec<&str> = grid.split('x').collect();
    if p.len() != 5 {
        return Err(format!("a grid is DTxN2xDZxDHxSPLIT, not {grid}").into());
    }
    let robot = brachia_tools::hook_robot()?;
    let model = ReducedTwoLink::new(&robot)?;
    let start = if hang {
        [-FRAC_PI_2, 0.0, 0.0]
    } else {
        let q = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).ok_or("no rear-hand pose")?;
        [q[0], 0.0, q[1]]
    };
    let bar = [0.34, 0.0];
    let s = ReachSettings {
        dt: p[0].parse()?,
        n_q2: p[1].parse()?,
        dz: p[2].parse()?,
        dh: p[3].parse()?,
        q2_max: 2.9,
        u_max: 15.0,
        q1_range: [-PI, 0.0],
        t_max: 1.3,
        bar,
        lambda: lambda(&model, bar, 2.9, 0.1),
        target_split: p[4].parse()?,
    };
    if mid {
        return meet_in_the_middle(&model, &s, start, &times);
    }
    if sweeps {
        return sweep_each(&model, &s, start, &times, passes, &refine);
    }
    let mut rb = ReachBox::new(&model, &s, start)?;
    println!(
        "start [q1, H, q2] = [{:.4}, {}, {:.4}]; grid: dt {} s, {} q2 cells, dz {} rad, dH {} kg m^2/s, target split {}; lambda {:.4} m per kg m^2/s; target: hand within {EPS} m of the bar and lambda |H| <= {EPS} m",
        start[0], start[1], start[2], s.dt, s.n_q2, s.dz, s.dh, s.target_split, s.lambda
    );
    println!("load before: {}", load());
    let t0 = Instant::now();
    println!("| T s | proven | margin m | hand bound m | cells | elapsed s |");
    println!("|---|---|---|---|---|---|");
    let mut peak = 0;
    for &t in &times {
        let k = (t / s.dt).round() as usize;
        while rb.steps() < k {
            rb.step()?;
            peak = peak.max(rb.cells());
            if rb.steps() % 10 == 0 {
                eprintln!(
                    "{:.3} s: extent {:?}, {} cells",
                    rb.time(),
                    rb.extent(),
                    rb.cells()
                );
            }
        }
        let tb = rb.target();
        if tb.margin <= EPS {
            for w in rb.witnesses(EPS, 3) {
                let q1 = w[1] - rb.model().phi(w[0]);
                eprintln!(
                    "  {t} s: a box at the target: q2 {:?}, q1 {q1:?}, H {:?}",
                    w[0], w[2]
                );
            }
        }
        println!(
            "| {:.3} | {} | {:.4} | {:.4} | {} | {:.1} |",
            rb.time(),
            if tb.margin > EPS { "yes" } else { "no" },
            tb.margin,
            tb.hand,
            rb.cells(),
            t0.elapsed().as_secs_f64()
        );
    }
    println!(
        "peak cells {peak}; {:.1} s; load after: {}",
        t0.elapsed().as_secs_f64(),
        load()
    );
    Ok(())
}

/// Step `rb` to the largest of `ks`, keeping a snapshot at each.
fn snapshots(rb: &mut ReachBox, ks: &[usize]) -> Result<Vec<(usize, Snapshot)>, ReachError> {
    let mut out = vec![];
    let last = ks.iter().copied().max().unwrap_or(0);
    loop {
        if ks.contains(&rb.steps()) {
            out.push((rb.steps(), rb.snapshot()));
        }
        if rb.steps() >= last {
            return Ok(out);
        }
        rb.step()?;
    }
}

/// The bound forward from the start to half the swing time, and forward from every state of the
/// target set (reversed in time, `H` reversed) over the other half: a swing time at which no box of
/// the first meets a box of the second is out of reach.
fn meet_in_the_middle(
    model: &ReducedTwoLink,
    s: &ReachSettings,
    start: [f64; 3],
    times: &[f64],
) -> Result<(), Box<dyn std::error::Error>> {
    let ks: Vec<usize> = times.iter().map(|t| (t / s.dt).round() as usize).collect();
    // every split of the swing time within SPLITS steps of its half is a proof on its own
    let splits = |k: usize| (k / 2).saturating_sub(SPLITS)..=(k / 2 + SPLITS).min(k);
    let k1: Vec<usize> = ks.iter().flat_map(|&k| splits(k)).collect();
    let k2: Vec<usize> = ks
        .iter()
        .flat_map(|&k| splits(k).map(move |a| k - a))
        .collect();
    let t0 = Instant::now();
    println!("load before: {}", load());
    let mut fwd = ReachBox::new(model, s, start)?;
    let nh = fwd.h_cells();
    let fs = snapshots(&mut fwd, &k1)?;
    println!(
        "forward bound to {:.3} s: {} cells, {:.1} s",
        fwd.time(),
        fwd.cells(),
        t0.elapsed().as_secs_f64()
    );
    let hm = EPS / s.lambda;
    let mut back: Vec<(usize, Snapshot)> = vec![];
    for [q1, q2] in fwd.model().poses_near(s.bar, EPS) {
        let mut rb = ReachBox::from_box(model, s, [q1, Iv::new(-hm, hm), q2])?;
        for (k, snap) in snapshots(&mut rb, &k2)? {
            match back.iter_mut().find(|(kk, _)| *kk == k) {
                Some((_, b)) => {
                    for (x, y) in b.iter_mut().zip(snap) {
                        x.extend(y);
                        x.sort_by_key(|c| c.0);
                    }
                }
                None => back.push((k, snap)),
            }
        }
        println!(
            "reversed bound from the target pose q1 {:?}, q2 {:?} to {:.3} s: {} cells, {:.1} s",
            q1,
            q2,
            rb.time(),
            rb.cells(),
            t0.elapsed().as_secs_f64()
        );
    }
    println!("| T s | split s + s | boxes that meet (fewest over the splits) | proven |");
    println!("|---|---|---|---|");
    for &k in &ks {
        let mut best = (usize::MAX, 0);
        for a in splits(k) {
            let fa = &fs
                .iter()
                .find(|(kk, _)| *kk == a)
                .ok_or("no forward snapshot")?
                .1;
            let bb = &back
                .iter()
                .find(|(kk, _)| *kk == k - a)
                .ok_or("no reversed snapshot")?
                .1;
            let n = meets_reversed(fa, bb, nh);
            if n < best.0 {
                best = (n, a);
            }
        }
        println!(
            "| {:.3} | {:.3} + {:.3} | {} | {} |",
            k as f64 * s.dt,
            best.1 as f64 * s.dt,
            (k - best.1) as f64 * s.dt,
            best.0,
            if best.0 == 0 { "yes" } else { "no" }
        );
    }
    println!(
        "{:.1} s; load after: {}",
        t0.elapsed().as_secs_f64(),
        load()
    );
    Ok(())
}

/// Forward-backward sweeps (`brachia_tools::reach_sweep`) at each swing time on its own, then on each
/// finer grid of `refine` (`z` and `H` cells) pruned by the grid before, until one proves it.
fn sweep_each(
    model: &ReducedTwoLink,
    s: &ReachSettings,
    start: [f64; 3],
    times: &[f64],
    passes: usize,
    refine: &[(usize, f64, f64, Option<f64>)],
) -> Result<(), Box<dyn std::error::Error>> {
    let hm = EPS / s.lambda;
    let target: Vec<[Iv; 3]> = ReachModel::new(model, s.u_max)?
        .poses_near(s.bar, EPS)
        .into_iter()
        .map(|[q1, q2]| [q1, Iv::new(-hm, hm), q2])
        .collect();
    let start = [start.map(|v| Iv::point(v).pad(1e-12))];
    println!(
        "dt {} s, {} q2 cells; at most {passes} sweeps a grid; load before: {}",
        s.dt,
        s.n_q2,
        load()
    );
    println!("| T s | q2 cells x dz rad x dH kg m^2/s (x dt s) | proven | boxes at T/2 per sweep (R reversed, F forward; 0@k: none at step k) | peak boxes | elapsed s | peak memory GB | load |");
    println!("|---|---|---|---|---|---|---|---|");
    for &t in times {
        let t0 = Instant::now();
        let mut prior = None;
        let grids = std::iter::once((s.n_q2, s.dz, s.dh, None)).chain(refine.iter().copied());
        for (n_q2, dz, dh, dt) in grids {
            let sg = ReachSettings {
                n_q2,
                dz,
                dh,
                dt: dt.unwrap_or(s.dt),
                ..s.clone()
            };
            let sw = SweepSettings {
                steps: (t / sg.dt).round() as usize,
                passes,
                stall: 0.98,
            };
            let out = sweep(model, &sg, &start, &target, &sw, prior.as_ref())?;
            let per: Vec<String> = out
                .passes
                .iter()
                .map(|p| {
                    let d = if p.direction == Direction::Forward {
                        "F"
                    } else {
                        "R"
                    };
                    if p.least == 0 {
                        format!("{d} 0@{}", p.least_at)
                    } else {
                        format!("{d} {}", p.mid)
                    }
                })
                .collect();
            println!(
                "| {:.3} | {n_q2} x {dz} x {dh}{} | {} | {} | {} | {:.1} | {:.2} | {} |",
                sw.steps as f64 * sg.dt,
                dt.map_or(String::new(), |d| format!(" x {d}")),
                if out.proven { "yes" } else { "no" },
                per.join(", "),
                out.passes.iter().map(|p| p.peak).max().unwrap_or(0),
                t0.elapsed().as_secs_f64(),
                peak_gb(),
                load()
            );
            if out.proven {
                break;
            }
            prior = Some(out);
        }
    }
    Ok(())
}
