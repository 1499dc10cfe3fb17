//! The reachable-set bound of the reduced two-link swing: its interval enclosures hold the model's
//! values at random points, `phi` integrates `M12/M11`, and the bound holds every motion tried (the
//! dynamic programme's own motions and random elbow-rate sequences integrated with RK4).
use brachia::model::ik_from_seed;
use brachia_tools::reach_box::{meets_reversed, widen_to_f32, ReachBox, ReachSettings};
use brachia_tools::reach_interval::Iv;
use brachia_tools::reach_model::ReachModel;
use brachia_tools::swing_dp::{DpSettings, ValueHistory};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;

mod common;
use common::{hook, reach_settings};

/// A random interval within `[lo, hi]` of width at most `w`, and a random point in it.
fn sample(rng: &mut ChaCha8Rng, lo: f64, hi: f64, w: f64) -> (Iv, f64) {
    let a = rng.gen_range(lo..hi);
    let b = (a + rng.gen_range(0.0..w)).min(hi);
    (Iv::new(a, b), rng.gen_range(a..=b))
}

#[test]
fn interval_enclosures_hold_the_models_values() {
    let (_, model) = hook();
    let m = ReachModel::new(&model, 15.0).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(31);
    for _ in 0..20000 {
        let w = [1e-6, 0.05, 0.5, 7.0][rng.gen_range(0..4)];
        let (x, t) = sample(&mut rng, -10.0, 10.0, w);
        assert!(
            x.sin().contains(t.sin()) && x.cos().contains(t.cos()),
            "{x:?} {t}"
        );
        let (q2, s2) = sample(&mut rng, -2.9, 2.9, w.min(1.0));
        let (q1, s1) = sample(&mut rng, -PI, 0.0, w.min(1.0));
        assert!(m.m11(q2).contains(model.m11(s2)), "{q2:?}");
        assert!(m.m12(q2).contains(model.m12(s2)), "{q2:?}");
        assert!(m.phi(q2).contains(m.phi_at(s2)), "{q2:?} {s2}");
        assert!(m.psi(q2).contains(s2 - m.phi_at(s2)), "{q2:?} {s2}");
        let q12 = q1 + q2;
        assert!(
            m.dv(q1, q12).contains(model.dv_dq1(s1, s2)),
            "{q1:?} {q2:?}"
        );
        assert!(m.dv(q1, q12).width() <= 2.0 * m.gmax());
        let hand = m.hand(q1, q12);
        let p = model.hand(s1, s2);
        assert!(
            hand[0].contains(p[0]) && hand[1].contains(p[1]),
            "{q1:?} {q2:?}"
        );
        assert!(model.dv_dq1(s1, s2).abs() <= m.gmax());
        let (a, b) = (rng.gen_range(-1e3..1e3), rng.gen_range(-1e3..1e3));
        let (ia, ib) = (Iv::new(a - 1.0, a), Iv::new(b, b + 2.0));
        assert!(
            (ia * ib).contains(a * b) && (ia - ib).contains(a - b) && (ia + ib).contains(a + b)
        );
        if let Some(r) = ib.recip() {
            assert!(r.contains(1.0 / (b + 1.0)));
        }
    }
    assert!(
        m.z_slack() < 1e-14,
        "the hook robot's links have no sin terms"
    );
}

#[test]
fn phi_integrates_m12_over_m11() {
    let (_, model) = hook();
    let m = ReachModel::new(&model, 15.0).unwrap();
    assert!(m.phi_at(0.0).abs() < 1e-15);
    // composite Simpson on 2000 panels per rad: error far below 1e-10
    let r = |s: f64| model.m12(s) / model.m11(s);
    for k in 0..=58 {
        let b = -2.9 + 0.1 * k as f64;
        let n = ((b.abs() * 2000.0).ceil() as usize).max(2) * 2;
        let h = b / n as f64;
        let mut acc = r(0.0) + r(b);
        for i in 1..n {
            acc += if i % 2 == 1 { 4.0 } else { 2.0 } * r(i as f64 * h);
        }
        let quad = acc * h / 3.0;
        assert!(
            (m.phi_at(b) - quad).abs() < 1e-10,
            "{b}: {} vs {quad}",
            m.phi_at(b)
        );
    }
}

fn settings(dt: f64) -> ReachSettings {
    reach_settings(dt)
}

#[test]
fn the_bound_holds_dp_motions_and_random_rk4_motions() {
    let (robot, model) = hook();
    let q0 = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).unwrap();
    let start = [q0[0], 0.0, q0[1]];
    let dt = 0.01;
    let steps = 50;
    // motions: the dynamic programme's (20 ms steps) and random piecewise-constant rates switching
    // every 7 ms (not on the bound's steps), RK4 in 1 ms substeps, the elbow stopped at its bound
    let dp = DpSettings {
        n_q1: 40,
        q1_range: Some([-PI, 0.0]),
        n_h: 32,
        n_q2: 32,
        h_max: 1.5,
        q2_max: 2.9,
        u_max: 15.0,
        n_u: 9,
        dt: 0.02,
        steps: steps / 2,
        substeps: 2,
        bar: [0.34, 0.0],
        drift_s: 0.1,
        keep_history: true,
    };
    let v = ValueHistory::solve(&model, &dp, &[start]);
    let mut paths: Vec<Vec<Option<[f64; 3]>>> = vec![];
    for k in [10, 18, 25] {
        let ro = v.rollout(start, k, 4 * dp.n_u).unwrap();
        let mut p = vec![None; steps + 1];
        for (j, x) in ro.x.iter().enumerate() {
            p[2 * j] = Some(*x);
        }
        paths.push(p);
    }
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for _ in 0..60 {
        let mut x = start;
        let mut p = vec![Some(x)];
        let mut u = 0.0;
        'm: for j in 1..=steps * 10 {
            if (j - 1) % 7 == 0 {
                u = if rng.gen_bool(0.3) {
                    15.0 * rng.gen_range(-1.0f64..1.0).signum()
                } else {
                    rng.gen_range(-15.0..15.0)
                };
            }
            let q2n = (x[2] + u * 0.001).clamp(-2.9, 2.9);
            x = model.step(x, (q2n - x[2]) / 0.001, 0.001, 1);
            if j % 10 == 0 {
                if !(-PI..=0.0).contains(&x[0]) {
                    break 'm;
                }
                p.push(Some(x));
            }
        }
        p.resize(steps + 1, None);
        paths.push(p);
    }
    let mut rb = ReachBox::new(&model, &settings(dt), start).unwrap();
    let mut checked = 0;
    for k in 0..=steps {
        for p in &paths {
            if let Some(x) = p[k] {
                let d = rb.distance(x);
                // RK4's error at 1 ms is far below 1e-9
                assert!(d <= 1e-9, "step {k}: {x:?} is {d:.3e} from the bound");
                checked += 1;
            }
        }
        if k < steps {
            rb.step().unwrap();
        }
    }
    assert!(checked > 2000, "{checked}");
    // the bound is not everything: a state far from the start's is out of it at 0.2 s
    let mut rb = ReachBox::new(&model, &settings(dt), start).unwrap();
    for _ in 0..20 {
        rb.step().unwrap();
    }
    assert!(rb.distance([-0.3, 0.0, 0.0]) > 0.1);
    assert!(rb.distance([q0[0], 2.0, q0[1]]) > 1.0);
}

#[test]
fn every_pose_with_the_hand_near_the_bar_is_in_a_target_box() {
    let (_, model) = hook();
    let m = ReachModel::new(&model, 15.0).unwrap();
    let eps = 0.001;
    let boxes = m.poses_near([0.34, 0.0], eps);
    assert_eq!(boxes.len(), 2);
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut hits = 0;
    for k in 0..200000 {
        // poses about each box, out to 0.02 rad beyond it
        let b = boxes[k % 2];
        let q1 = rng.gen_range(b[0].lo - 0.02..b[0].hi + 0.02);
        let q2 = rng.gen_range(b[1].lo - 0.02..b[1].hi + 0.02);
        let p = model.hand(q1, q2);
        if (p[0] - 0.34).hypot(p[1]) <= eps {
            hits += 1;
            assert!(
                boxes.iter().any(|b| b[0].contains(q1) && b[1].contains(q2)),
                "{q1} {q2}"
            );
        }
    }
    // near the edge of the disc too: poses on a circle of radius eps about the bar
    for k in 0..720 {
        let a = 2.0 * PI * k as f64 / 720.0;
        let target = [0.34 + eps * 0.999_999 * a.cos(), eps * 0.999_999 * a.sin()];
        for seed in [[-1.0, 1.9], [1.0, -1.9]] {
            let q = brachia::model::ik_from_seed(model.robot(), &seed, target).unwrap();
            assert!(
                boxes
                    .iter()
                    .any(|b| b[0].contains(q[0]) && b[1].contains(q[1])),
                "{q:?}"
            );
        }
    }
    assert!(hits > 1000, "{hits}");
    // the boxes are small: a few mrad
    assert!(boxes
        .iter()
        .all(|b| b[0].width() < 0.03 && b[1].width() < 0.03));
}

#[test]
fn forward_and_reversed_bounds_meet_on_a_motion() {
    let (robot, model) = hook();
    let q0 = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).unwrap();
    let start = [q0[0], 0.0, q0[1]];
    let s = settings(0.01);
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for _ in 0..3 {
        // a random motion of 0.2 s; the reversed bound starts at its end with H reversed
        let mut x = start;
        for j in 0..200 {
            let u: f64 = if j % 9 == 0 {
                rng.gen_range(-15.0..15.0)
            } else {
                5.0
            };
            let q2n = (x[2] + u * 0.001).clamp(-2.9, 2.9);
            x = model.step(x, (q2n - x[2]) / 0.001, 0.001, 1);
        }
        let mut a = ReachBox::new(&model, &s, start).unwrap();
        let end = [
            Iv::point(x[0]).pad(1e-9),
            Iv::point(-x[1]).pad(1e-9),
            Iv::point(x[2]).pad(1e-9),
        ];
        let mut b = ReachBox::from_box(&model, &s, end).unwrap();
        for _ in 0..10 {
            a.step().unwrap();
            b.step().unwrap();
        }
        assert!(a.meets_reversed(&b.snapshot()) > 0);
        assert!(meets_reversed(&a.snapshot(), &b.snapshot(), a.h_cells()) > 0);
    }
    // and a state out of reach in 0.2 s (link 1 near horizontal, the arm straight) is not met
    let mut a = ReachBox::new(&model, &s, start).unwrap();
    let far = [-0.3, 0.0, 0.0].map(|v| Iv::point(v).pad(1e-9));
    let mut b = ReachBox::from_box(&model, &s, far).unwrap();
    for _ in 0..10 {
        a.step().unwrap();
        b.step().unwrap();
    }
    assert_eq!(a.meets_reversed(&b.snapshot()), 0);
}

#[test]
fn boxes_stored_in_f32_hold_the_f64_boxes() {
    // random boxes of every scale and sign: the f32 box holds the f64 one, within one f32 unit
    let mut rng = ChaCha8Rng::seed_from_u64(32);
    let mut rounded = 0;
    for _ in 0..100_000 {
        let scale = [1e-9, 1e-3, 0.4, 3.0, 12.0][rng.gen_range(0..5)];
        let mut b = [0.0f64; 4];
        for k in [0, 2] {
            let a = rng.gen_range(-scale..scale);
            let w = rng.gen_range(0.0..scale * 1e-3);
            b[k] = a;
            b[k + 1] = a + w;
        }
        if rng.gen_bool(0.05) {
            // ends that are f32 numbers stay as they are
            b = b.map(|v| f64::from(v as f32));
        }
        let w = widen_to_f32(&b);
        for k in [0, 2] {
            let (lo, hi) = (f64::from(w[k]), f64::from(w[k + 1]));
            assert!(lo <= b[k] && b[k + 1] <= hi, "{b:?} -> {w:?}");
            // the nearest f32 numbers outside: one unit further in would cut the box
            assert!(f64::from(w[k].next_up()) > b[k], "{b:?} -> {w:?}");
            assert!(f64::from(w[k + 1].next_down()) < b[k + 1], "{b:?} -> {w:?}");
            if lo != b[k] {
                rounded += 1;
            }
        }
    }
    assert!(rounded > 100_000, "{rounded} ends rounded");
    // a bound's snapshot holds each of its boxes, cell by cell
    let (robot, model) = hook();
    let q0 = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).unwrap();
    let mut rb = ReachBox::new(&model, &settings(0.01), [q0[0], 0.0, q0[1]]).unwrap();
    for _ in 0..20 {
        rb.step().unwrap();
    }
    let snap = rb.snapshot();
    assert!(rb.cells() > 1000);
    for (a, b) in rb.boxes().iter().zip(&snap) {
        assert_eq!(a.len(), b.len());
        for ((i, x), (j, y)) in a.iter().zip(b) {
            assert_eq!(i, j);
            let y = y.map(f64::from);
            assert!(y[0] <= x[0] && x[1] <= y[1] && y[2] <= x[2] && x[3] <= y[3]);
        }
    }
}
