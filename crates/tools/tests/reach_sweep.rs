//! Forward-backward sweeps of the reachable-set bound: every motion from the start to the target
//! stays in every step of the sweeps (random RK4 motions), pruning removes boxes, and a target out of
//! reach is proven so.
use brachia::model::ik_from_seed;
use brachia_tools::reach_box::{ReachBox, ReachSettings, Snapshot};
use brachia_tools::reach_interval::Iv;
use brachia_tools::reach_sweep::{sweep, Direction, SweepSettings};
use brachia_tools::reduced_two_link::ReducedTwoLink;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

mod common;
use common::{hook, reach_settings};

fn settings() -> ReachSettings {
    reach_settings(0.01)
}

/// A motion of `ms` ms from `x`: the rate `rate(j)` over each ms, RK4, the elbow stopped at its bound;
/// the state every `every` ms.
fn motion(
    model: &ReducedTwoLink,
    mut x: [f64; 3],
    (ms, every): (usize, usize),
    rate: impl Fn(usize) -> f64,
) -> Vec<[f64; 3]> {
    let mut out = vec![x];
    for j in 0..ms {
        let q2n = (x[2] + rate(j) * 0.001).clamp(-2.9, 2.9);
        x = model.step(x, (q2n - x[2]) / 0.001, 0.001, 1);
        if (j + 1) % every == 0 {
            out.push(x);
        }
    }
    out
}

/// The start, a target of two boxes about a reference motion's end after `k` steps of 10 ms, and the
/// random motions about the reference that end in the target with link 1 below the bar (states
/// every `every` ms).
type Motions = ([f64; 3], [[Iv; 3]; 2], Vec<Vec<[f64; 3]>>);
fn motions_to_a_target(model: &ReducedTwoLink, k: usize, every: usize) -> Motions {
    let (robot, _) = hook();
    let q0 = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).unwrap();
    let x0 = [q0[0], 0.0, q0[1]];
    let per = 10 / every;
    // a reference rate over 0.3 s and random motions about it; the target is a box about the
    // reference's end, in two parts (the union of two bounds)
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let knots: Vec<f64> = (0..10).map(|_| rng.gen_range(-12.0..12.0)).collect();
    let reference = motion(model, x0, (10 * k, every), |j| knots[j / 30]);
    let e = reference[k * per];
    let target = [
        [
            Iv::point(e[0]).pad(0.04),
            Iv::point(e[1]).pad(0.03),
            Iv::new(e[2] - 0.15, e[2]),
        ],
        [
            Iv::point(e[0]).pad(0.04),
            Iv::point(e[1]).pad(0.03),
            Iv::new(e[2], e[2] + 0.15),
        ],
    ];
    let inside = |x: [f64; 3]| {
        target
            .iter()
            .any(|b| b[0].contains(x[0]) && b[1].contains(x[1]) && b[2].contains(x[2]))
    };
    let mut hits: Vec<Vec<[f64; 3]>> = vec![reference.clone()];
    for _ in 0..400 {
        let noise: Vec<f64> = (0..k * 10 / 7 + 1)
            .map(|_| rng.gen_range(-3.0..3.0))
            .collect();
        let m = motion(model, x0, (10 * k, every), |j| {
            (knots[j / 30] + noise[j / 7]).clamp(-15.0, 15.0)
        });
        if inside(m[k * per]) && m.iter().all(|x| (-PI..=0.0).contains(&x[0])) {
            hits.push(m);
        }
    }
    assert!(hits.len() >= 10, "{} motions reach the target", hits.len());
    (x0, target, hits)
}

#[test]
fn sweeps_hold_every_motion_to_the_target_and_prune() {
    let (_, model) = hook();
    let s = settings();
    let k = 30;
    let (x0, target, hits) = motions_to_a_target(&model, k, 10);
    let start = [x0.map(|v| Iv::point(v).pad(1e-12))];
    let sw = SweepSettings {
        steps: k,
        passes: 4,
        stall: 1.0,
    };
    let out = sweep(&model, &s, &start, &target, &sw, None).unwrap();
    assert!(!out.proven);
    assert_eq!(out.passes.len(), 5);
    assert_eq!(out.passes[1].direction, Direction::Forward);
    assert_eq!(out.forward.len(), k + 1);
    assert_eq!(out.reversed.len(), k + 1);
    let probe = ReachBox::new(&model, &s, x0).unwrap();
    for m in &hits {
        for (j, x) in m.iter().enumerate() {
            let d = probe.distance_in(&out.forward[j], *x);
            assert!(d <= 1e-9, "forward step {j}: {x:?} is {d:.3e} out");
            let r = [x[0], -x[1], x[2]];
            let d = probe.distance_in(&out.reversed[k - j], r);
            assert!(d <= 1e-9, "reversed step {}: {r:?} is {d:.3e} out", k - j);
        }
    }
    // the sweeps prune: fewer boxes at the end than the unpruned bound from the start holds
    let mut free = ReachBox::new(&model, &s, x0).unwrap();
    for _ in 0..k {
        free.step().unwrap();
    }
    let kept: usize = out.forward[k].iter().map(Vec::len).sum();
    assert!(
        kept * 2 < free.cells(),
        "{kept} boxes kept of {}",
        free.cells()
    );
    // and later sweeps keep no more than earlier ones in the same direction
    assert!(out.passes[3].total <= out.passes[1].total);
    assert!(out.passes[4].total <= out.passes[2].total);
    // refined: cells of half the width in q2, z and H, pruned by the coarse sweeps from the first
    // step on, hold
    // every motion too, with fewer boxes than the coarse grid's unrefined start would give
    let fine = ReachSettings {
        n_q2: 116,
        dz: 0.01,
        dh: 0.005,
        ..s.clone()
    };
    let sw2 = SweepSettings { passes: 2, ..sw };
    let ref_out = sweep(&model, &fine, &start, &target, &sw2, Some(&out)).unwrap();
    assert!(!ref_out.proven);
    let probe = ReachBox::new(&model, &fine, x0).unwrap();
    for m in &hits {
        for (j, x) in m.iter().enumerate() {
            let d = probe.distance_in(&ref_out.forward[j], *x);
            assert!(d <= 1e-9, "refined forward step {j}: {x:?} is {d:.3e} out");
            let r = [x[0], -x[1], x[2]];
            let d = probe.distance_in(&ref_out.reversed[k - j], r);
            assert!(
                d <= 1e-9,
                "refined reversed step {}: {r:?} is {d:.3e} out",
                k - j
            );
        }
    }
    // the refined boxes are narrower: their volumes (z x H x the q2 cell) summed over every step fall
    // below the coarse ones'
    let volume = |store: &[Snapshot]| -> f64 {
        let w = 5.8 / store[0].len() as f64;
        store
            .iter()
            .flatten()
            .flatten()
            .map(|(_, b)| f64::from(b[1] - b[0]) * f64::from(b[3] - b[2]) * w)
            .sum()
    };
    let (vf, vc) = (volume(&ref_out.forward), volume(&out.forward));
    assert!(vf < 0.8 * vc, "refined {vf:.3e}, coarse {vc:.3e}");
}

#[test]
fn sweeps_prove_a_target_out_of_reach() {
    let (robot, model) = hook();
    let q0 = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).unwrap();
    let start = [[q0[0], 0.0, q0[1]].map(|v| Iv::point(v).pad(1e-12))];
    // link 1 near horizontal with the arm straight, at rest: out of reach in 0.2 s
    let far = [[-0.3, 0.0, 0.0].map(|v| Iv::point(v).pad(1e-3))];
    let sw = SweepSettings {
        steps: 20,
        passes: 4,
        stall: 1.0,
    };
    let out = sweep(&model, &settings(), &start, &far, &sw, None).unwrap();
    assert!(out.proven);
    assert_eq!(out.passes.last().unwrap().least, 0);
    // a set is in reach of itself in no time
    let sw0 = SweepSettings {
        steps: 0,
        passes: 2,
        stall: 1.0,
    };
    let out = sweep(&model, &settings(), &far, &far, &sw0, None).unwrap();
    assert!(!out.proven);
}

#[test]
fn sparse_and_dense_steps_give_the_same_boxes() {
    let (robot, model) = hook();
    let q0 = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).unwrap();
    let x0 = [q0[0], 0.0, q0[1]];
    let mut dense = ReachBox::new(&model, &settings(), x0).unwrap();
    let mut sparse = ReachBox::new(&model, &settings(), x0).unwrap();
    sparse.set_dense_cells(0);
    for _ in 0..15 {
        dense.step().unwrap();
        sparse.step().unwrap();
    }
    assert!(dense.cells() > 1000);
    assert_eq!(dense.boxes(), sparse.boxes());
}

#[test]
fn half_steps_pruned_by_a_coarser_grid_hold_every_motion() {
    // the coarse grid at 10 ms, then a finer one at 5 ms pruned by it at every other step
    let (_, model) = hook();
    let s = settings();
    let k = 30;
    let (x0, target, hits) = motions_to_a_target(&model, k, 5);
    let start = [x0.map(|v| Iv::point(v).pad(1e-12))];
    let sw = SweepSettings {
        steps: k,
        passes: 2,
        stall: 1.0,
    };
    let coarse = sweep(&model, &s, &start, &target, &sw, None).unwrap();
    let fine = ReachSettings {
        dt: 0.005,
        n_q2: 116,
        dz: 0.005,
        dh: 0.0025,
        ..s.clone()
    };
    let sw2 = SweepSettings {
        steps: 2 * k,
        passes: 2,
        stall: 1.0,
    };
    let out = sweep(&model, &fine, &start, &target, &sw2, Some(&coarse)).unwrap();
    assert!(!out.proven);
    assert_eq!(out.steps, 2 * k);
    assert_eq!(out.forward.len(), 2 * k + 1);
    let probe = ReachBox::new(&model, &fine, x0).unwrap();
    for m in &hits {
        assert_eq!(m.len(), 2 * k + 1);
        for (j, x) in m.iter().enumerate() {
            let d = probe.distance_in(&out.forward[j], *x);
            assert!(d <= 1e-9, "forward step {j}: {x:?} is {d:.3e} out");
            let r = [x[0], -x[1], x[2]];
            let d = probe.distance_in(&out.reversed[2 * k - j], r);
            assert!(
                d <= 1e-9,
                "reversed step {}: {r:?} is {d:.3e} out",
                2 * k - j
            );
        }
    }
    // the coarse grid prunes the fine one: the first reversed sweep keeps fewer boxes at the middle
    // than without it
    let sw0 = SweepSettings { passes: 0, ..sw2 };
    let free = sweep(&model, &fine, &start, &target, &sw0, None).unwrap();
    let (a, b) = (out.passes[0].mid, free.passes[0].mid);
    assert!(b > 0 && 2 * a < b, "{a} of {b}");
    // a prior whose steps do not divide the sweep's, or of another time, is refused
    let sw3 = SweepSettings { steps: 45, ..sw2 };
    assert!(sweep(&model, &fine, &start, &target, &sw3, Some(&coarse)).is_err());
    let other_time = ReachSettings {
        dt: 0.004,
        ..fine.clone()
    };
    assert!(sweep(&model, &other_time, &start, &target, &sw2, Some(&coarse)).is_err());
}
