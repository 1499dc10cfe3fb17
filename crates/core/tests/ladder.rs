//! The ladder's sequencing in the library (`brachia::ladder`): the reach rule, the grip-switch map
//! with the grip and world frames and each swing's task (a swing's capture is judged by the run
//! layer's rule: crates/run/tests/capture_rule.rs).

use brachia::ladder::{
    chains, check_bars, holding_hand, joint_swing_task, swing_task, world_joints, Bar,
    MAX_SPACING_OF_SPAN, MIN_SPACING_OF_SPAN,
};
use brachia::model::{switch_grip, Circle};
use brachia::{Error, Robot};

fn bar(x: f64, y: f64) -> Bar {
    Bar { x, y }
}

#[test]
fn the_reach_rule_names_the_bar_out_of_reach_or_too_close() {
    let robot = Robot::paper();
    let span = robot.reach();
    let ok = [bar(0.0, 0.0), bar(0.5 * span, 0.0), bar(span, 0.0)];
    check_bars(&robot, &ok, "l.toml").unwrap();
    let far = [bar(0.0, 0.0), bar(1.01 * MAX_SPACING_OF_SPAN * span, 0.0)];
    match check_bars(&robot, &far, "l.toml").unwrap_err() {
        Error::InvalidValue { field, reason, .. } => {
            assert_eq!(field, "ladder.bars[1]");
            assert!(reason.contains("out of reach"), "{reason}");
        }
        e => panic!("{e}"),
    }
    let near = [bar(0.0, 0.0), bar(0.99 * MIN_SPACING_OF_SPAN * span, 0.0)];
    let e = check_bars(&robot, &near, "l.toml").unwrap_err().to_string();
    assert!(e.contains("too close"), "{e}");
    let back = [bar(0.0, 0.0), bar(0.5 * span, 0.0), bar(0.01, 0.0)];
    let e = check_bars(&robot, &back, "l.toml").unwrap_err().to_string();
    assert!(
        e.contains("ladder.bars[2]") && e.contains("earlier bar"),
        "{e}"
    );
    let e = check_bars(&robot, &ok[..1], "l.toml")
        .unwrap_err()
        .to_string();
    assert!(e.contains("1 bars"), "{e}");
}

#[test]
fn the_hands_take_turns_and_the_chain_stays_put_across_a_switch() {
    let robot = Robot::paper();
    let ch = chains(&robot).unwrap();
    assert_eq!(
        (0..5).map(holding_hand).collect::<Vec<_>>(),
        [0, 1, 0, 1, 0]
    );
    let grip = [0.3, -0.1];
    let x = [-2.0, 0.4, -1.2, 0.3, 0.0, 0.0, 0.0, 0.0];
    let before = world_joints(&ch[holding_hand(0)], grip, &x[..4], holding_hand(0));
    // hand A at the grip, hand B (the swing hand) at the end, in the parameters file's order
    assert_eq!(before[0], grip);
    let s = switch_grip(&ch[holding_hand(0)], grip, &x).unwrap();
    assert_eq!(s.impact_energy_j, 0.0);
    let after = world_joints(&ch[holding_hand(1)], s.grip, &s.x[..4], holding_hand(1));
    assert_eq!(before.len(), after.len());
    for (a, b) in before.iter().zip(&after) {
        assert!(
            (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12,
            "{a:?} {b:?}"
        );
    }
    // the new grip is hand B: the last point in the parameters file's order
    assert!((after[4][0] - s.grip[0]).abs() < 1e-12 && (after[4][1] - s.grip[1]).abs() < 1e-12);
}

#[test]
fn a_swing_task_is_its_bar_and_obstacles_in_the_grip_frame() {
    let bars = [bar(0.0, 0.0), bar(1.0, 0.1), bar(2.0, -0.1)];
    let obstacles = [Circle {
        center: [1.5, -0.3],
        radius: 0.08,
    }];
    let grip = [1.01, 0.09];
    let t = swing_task(&bars, &obstacles, &[-2.0, 0.1], &[0.2, 0.0], grip, 2);
    assert_eq!(t.q0, [-2.0, 0.1]);
    assert_eq!(t.qd0, [0.2, 0.0]);
    assert_eq!(t.target, [2.0 - 1.01, -0.1 - 0.09]);
    assert_eq!(t.obstacles[0].center, [1.5 - 1.01, -0.3 - 0.09]);
    assert_eq!(t.obstacles[0].radius, 0.08);
    let j = joint_swing_task(vec![0.0; 4], grip, &bars[2..], &obstacles, true);
    assert_eq!(j.bars, [grip, [2.0, -0.1]]);
    assert_eq!(j.obstacles[0].center, [1.5, -0.3]);
    assert!(j.rest_at_switches);
}
