//! One capture rule for `brachia track` and the ladder's gripper (`success::CaptureRule`): on the same
//! log, with the ladder's radius and speed, the track's judge (`CaptureRule::capture`) and the ladder's
//! (`traverse::swing_capture`, in the swing's grip frame) give the same verdict, distance and speed;
//! they differ only in when they look (the track at every row, the ladder where its gripper closes,
//! at the end of the swing).

use brachia::sim::ClosedLoopLog;
use brachia::Robot;
use brachia_run::ladder::Ladder;
use brachia_run::scenario::parse_toml;
use brachia_run::success::{hand_at_bar, CaptureRule, CAPTURE_SPEED_M_S, SUCCESS_RADIUS_M};
use brachia_run::traverse::swing_capture;

const GRIP: [f64; 2] = [0.3, 0.1];
const HANG: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];
const END: [f64; 4] = [-0.9, 0.4, -1.2, 0.3];

fn ladder(extra: &str) -> Ladder {
    parse_toml(
        &format!("bars = [[0.3, 0.1], [0.9, 0.1]]\n{extra}"),
        "ladder.toml",
    )
    .unwrap()
}

/// A log of `robot` in its grip frame: rows at `qs` (all at rest but the last, moving at `qd_end`),
/// 0.5 s apart.
fn log(robot: &Robot, qs: &[[f64; 4]], qd_end: [f64; 4]) -> ClosedLoopLog {
    let mut l = ClosedLoopLog {
        n: robot.n(),
        ..ClosedLoopLog::default()
    };
    for (k, q) in qs.iter().enumerate() {
        l.t.push(0.5 * k as f64);
        l.x.extend_from_slice(q);
        let last = k + 1 == qs.len();
        l.x.extend_from_slice(if last { &qd_end } else { &[0.0; 4] });
    }
    l
}

/// The bar, world, `offset` (m, along x) from where the hand of `robot` is at `q`.
fn bar_near(robot: &Robot, q: &[f64], offset: f64) -> [f64; 2] {
    let ee = robot.ee_position(q);
    [GRIP[0] + ee[0] + offset, GRIP[1] + ee[1]]
}

/// A joint rate of the last joint that moves the hand at `speed` m/s at `END`.
fn qd_for_speed(robot: &Robot, speed: f64) -> [f64; 4] {
    let v = robot.ee_velocity(&END, &[0.0, 0.0, 0.0, 1.0]);
    [0.0, 0.0, 0.0, speed / v[0].hypot(v[1])]
}

#[test]
fn the_ladder_and_track_judge_the_same_log_the_same_way() {
    let robot = Robot::paper();
    let l = ladder("");
    let rule = l.capture_rule();
    assert_eq!((rule.radius_m, rule.speed_m_s), (0.02, 0.1));
    // (offset of the bar from the final hand, hand speed at the end, caught by the ladder's rule)
    let cases = [
        (0.0, 0.0, true),
        (0.015, 0.0, true),
        (0.03, 0.0, false),
        (0.0, 0.05, true),
        (0.0, 0.3, false),
    ];
    for (offset, speed, caught) in cases {
        let lg = log(&robot, &[HANG, HANG, END], qd_for_speed(&robot, speed));
        let bar = bar_near(&robot, &END, offset);
        let ladder_says = swing_capture(&l, &robot, GRIP, &lg, bar).unwrap();
        let target = [bar[0] - GRIP[0], bar[1] - GRIP[1]];
        let track_says = rule.capture(&robot, &lg, 1.0, target);
        let what = format!("offset {offset} m, speed {speed} m/s");
        assert_eq!(ladder_says.captures, caught, "{what}");
        assert_eq!(track_says.reaches_bar, caught, "{what}");
        assert_eq!(track_says.row, 2, "{what}");
        assert!((ladder_says.distance_m - offset).abs() < 1e-12, "{what}");
        assert_eq!(track_says.bar_error_m, ladder_says.distance_m, "{what}");
        assert_eq!(track_says.hand_speed_m_s, ladder_says.speed_m_s, "{what}");
        assert!((ladder_says.speed_m_s - speed).abs() < 1e-12, "{what}");
    }
}

#[test]
fn the_rule_takes_the_ladders_numbers_and_its_defaults_are_the_runs() {
    let robot = Robot::paper();
    // 0.3 m/s: over the ladder's default capture speed, under the run's success rule
    let lg = log(&robot, &[HANG, END], qd_for_speed(&robot, 0.3));
    let bar = bar_near(&robot, &END, 0.0);
    let target = [bar[0] - GRIP[0], bar[1] - GRIP[1]];
    assert!(
        !swing_capture(&ladder(""), &robot, GRIP, &lg, bar)
            .unwrap()
            .captures
    );
    let fast = ladder("capture_speed = 0.5\ncapture_radius = 0.02\n");
    assert_eq!(fast.capture_rule(), CaptureRule::SUCCESS);
    assert!(
        swing_capture(&fast, &robot, GRIP, &lg, bar)
            .unwrap()
            .captures
    );
    assert!(brachia_run::success::capture(&robot, &lg, 0.5, target).reaches_bar);
    // the free functions are the success rule's methods
    assert_eq!(
        CaptureRule::SUCCESS,
        CaptureRule {
            radius_m: SUCCESS_RADIUS_M,
            speed_m_s: CAPTURE_SPEED_M_S
        }
    );
    assert_eq!(
        hand_at_bar(&robot, lg.x(1), target),
        CaptureRule::SUCCESS.hand_at_bar(&robot, lg.x(1), target)
    );
    // a tighter ladder radius refuses what the run's rule takes
    let tight = ladder("capture_radius = 0.001\n");
    let near = bar_near(&robot, &END, 0.005);
    let still = log(&robot, &[HANG, END], [0.0; 4]);
    assert!(
        !swing_capture(&tight, &robot, GRIP, &still, near)
            .unwrap()
            .captures
    );
    assert!(
        swing_capture(&ladder(""), &robot, GRIP, &still, near)
            .unwrap()
            .captures
    );
}

#[test]
fn only_when_they_look_differs() {
    // the hand passes over the bar at rest half-way and ends 3 cm off: the track's run ends at that
    // first capture; the ladder's gripper closes at the end of the swing and misses
    let robot = Robot::paper();
    let l = ladder("");
    let lg = log(&robot, &[HANG, END, HANG], [0.0; 4]);
    let bar = bar_near(&robot, &END, 0.0);
    let target = [bar[0] - GRIP[0], bar[1] - GRIP[1]];
    let track_says = l.capture_rule().capture(&robot, &lg, 1.0, target);
    assert!(track_says.reaches_bar && track_says.row == 1);
    assert_eq!(track_says.capture_t_s, Some(0.5));
    let ladder_says = swing_capture(&l, &robot, GRIP, &lg, bar).unwrap();
    assert!(!ladder_says.captures && ladder_says.distance_m > 0.02);
    // and an empty log has nothing to judge
    let empty = ClosedLoopLog::default();
    assert!(swing_capture(&l, &robot, GRIP, &empty, bar).is_none());
}

#[test]
fn the_ladders_judge_measures_the_hand_in_the_world_from_its_grip() {
    let robot = Robot::paper();
    let l = ladder("");
    let ee = robot.ee_position(&HANG);
    let on_bar = [GRIP[0] + ee[0], GRIP[1] + ee[1]];
    let still = log(&robot, &[HANG], [0.0; 4]);
    let h = swing_capture(&l, &robot, GRIP, &still, on_bar).unwrap();
    assert!(h.distance_m < 1e-12 && h.speed_m_s == 0.0 && h.captures);
    let h = swing_capture(
        &l,
        &robot,
        GRIP,
        &still,
        [on_bar[0] + 0.03, on_bar[1] - 0.04],
    )
    .unwrap();
    assert!((h.distance_m - 0.05).abs() < 1e-12 && !h.captures);
    // turning the whole chain about the grip at w moves the hand at w times its distance from the grip
    let turning = log(&robot, &[HANG], [0.5, 0.0, 0.0, 0.0]);
    let h = swing_capture(&l, &robot, GRIP, &turning, on_bar).unwrap();
    assert!(
        (h.speed_m_s - 0.5 * ee[0].hypot(ee[1])).abs() < 1e-12,
        "{h:?}"
    );
}
