//! The robots of the parameter study: each arm's links, the robot scaled to a ratio r2 and an arm
//! length, and the start pose with both hands on their bars.

use brachia::model::{Robot, RobotParams};
use brachia::Error;

/// Names the settings in error messages when they do not come from a file.
pub(super) const SRC: &str = "<parameter study settings>";

/// Links of an arm and how the study's robots are built from them, for `n` links (see the module
/// docs): `n / 2` links per arm, counted from each hand, and for an odd `n` a middle link between the
/// two arms, half of it counted in each arm's length. Errors, naming `field` of `src`, for a link count
/// the rule has no meaning for: `n = 2` (each arm is its hand link alone, so `r2` would be 1 for every
/// robot) and `n` outside `2..=MAX_LINKS`.
pub fn check_study_links(n: usize, src: &str, field: &str) -> Result<(), Error> {
    if n == 2 {
        return Err(Error::invalid(
            src,
            field,
            "2 links",
            "the parameter study varies r2 = L1 / (length of the arm), the hand link's share of its \
             arm; a 2-link robot's arms are its hand links alone (r2 = 1 always), so it needs 3 to 12 \
             links (docs/parameter-study.md); plan, track and simulate take 2 links",
        ));
    }
    if !(3..=brachia::limits::MAX_LINKS).contains(&n) {
        return Err(Error::invalid(
            src,
            field,
            format!("{n} links"),
            format!(
                "the parameter study needs 3 to {} links (docs/parameter-study.md)",
                brachia::limits::MAX_LINKS
            ),
        ));
    }
    Ok(())
}

/// Link lengths of the study robot of `r2` with arms of `arm_length_m` (m), from the base's lengths
/// `base` (n >= 3, checked by the caller): the hand links `L1 = Ln = r2 A`; the rest of each arm,
/// `(1 - r2) A`, shared by the arm's inner links (and, for an odd n, half the middle link) in
/// proportion to the base's lengths averaged over the mirror pairs (`(L_i + L_{n+1-i}) / 2`; the
/// middle link counts half). Mirrored by construction; for n = 4 the one inner link of an arm takes
/// all of `(1 - r2) A` (its share is `x / x = 1` exactly), so `L2 = L3 = (1 - r2) A` as before.
pub(super) fn study_lengths(base: &[f64], r2: f64, arm_length_m: f64) -> Vec<f64> {
    let n = base.len();
    let k = n / 2; // links per arm, counted from the hand, without the middle link of an odd n
    let (lower, upper) = (r2 * arm_length_m, (1.0 - r2) * arm_length_m);
    // weights of the inner parts: links 2..=k (0-based 1..k) as mirror pairs, then half the middle link
    let mut w: Vec<f64> = (1..k).map(|i| base[i] + base[n - 1 - i]).collect();
    if n % 2 == 1 {
        w.push(base[k]);
    }
    let total: f64 = w.iter().sum();
    let mut len = vec![0.0; n];
    len[0] = lower;
    len[n - 1] = lower;
    for i in 1..k {
        len[i] = upper * (w[i - 1] / total);
        len[n - 1 - i] = len[i];
    }
    if n % 2 == 1 {
        // the arms' two halves of the middle link
        len[k] = 2.0 * (upper * (w[k - 1] / total));
    }
    len
}

/// The base robot scaled to the hand link's share `r2` of arms of `arm_length_m` (see the module docs
/// for the rule): for 4 links `r2 = L1 / (L1 + L2)`. `base` must have 3..=12 links
/// ([`check_study_links`]); the result is validated.
pub fn scaled_params(base: &RobotParams, r2: f64, arm_length_m: f64) -> Result<RobotParams, Error> {
    check_study_links(base.links.len(), &base.name, "links")?;
    if !(r2.is_finite() && r2 > 0.0 && r2 < 1.0) {
        return Err(Error::invalid(SRC, "r2", r2, "must lie in (0, 1)"));
    }
    if !(arm_length_m.is_finite() && arm_length_m > 0.0) {
        return Err(Error::invalid(
            SRC,
            "arm_length_m",
            arm_length_m,
            "must be finite and > 0",
        ));
    }
    let base_len: Vec<f64> = base.links.iter().map(|l| l.length).collect();
    let lengths = study_lengths(&base_len, r2, arm_length_m);
    let mut p = base.clone();
    for (l, length) in p.links.iter_mut().zip(lengths) {
        let s = length / l.length;
        l.length = length;
        l.mass *= s;
        l.com *= s;
        l.inertia *= s * s * s;
    }
    p.name = format!("{} scaled to r2 = {r2}", base.name);
    p.validate(&format!("{} (r2 = {r2})", base.name))?;
    Ok(p)
}

/// Wrap an angle to (-pi, pi].
pub(super) fn wrap(a: f64) -> f64 {
    let pi = std::f64::consts::PI;
    let mut a = a.rem_euclid(2.0 * pi);
    if a > pi {
        a -= 2.0 * pi;
    }
    a
}

/// The start pose with the EE at `start` and both arms straight (every joint inside an arm at 0),
/// the lower of the two mirror-image solutions. For an even n the arms (links `1..=n/2` and the rest)
/// meet at the shoulder, joint `n/2 + 1`, placed at distance `L1 + .. + L(n/2)` from the grip and the
/// other arm's length from `start`: for 4 links `[q1, 0, q3, 0]`. For an odd n the middle link joins
/// the arms (joints `(n+1)/2` and `(n+3)/2` bend) and lies parallel to the line from the grip to
/// `start`, the arms symmetric about its perpendicular bisector (this needs arms of equal length, as
/// every study robot has). Returns q (rad; q1 absolute, the rest relative, wrapped to (-pi, pi]).
/// Errors when no such pose exists.
pub fn start_pose(robot: &Robot, start: [f64; 2]) -> Result<Vec<f64>, Error> {
    let n = robot.n();
    let k = n / 2;
    let d = start[0].hypot(start[1]);
    let u = [start[0] / d, start[1] / d];
    let w = [u[1], -u[0]];
    let lower = |c: [[f64; 2]; 2]| if c[0][1] <= c[1][1] { c[0] } else { c[1] };
    let mut q = vec![0.0; n];
    if n.is_multiple_of(2) {
        let a: f64 = robot.lengths()[..k].iter().sum();
        let b: f64 = robot.lengths()[k..].iter().sum();
        if !(d > 0.0 && d <= a + b && d >= (a - b).abs()) {
            return Err(Error::InfeasibleTask(format!(
                "no straight-arm pose puts the EE at ({:.3}, {:.3}): arms of {a:.3} m and {b:.3} m",
                start[0], start[1]
            )));
        }
        // shoulder = along * u + h * w, u = start / d, w = u rotated by -90 deg; pick the lower one
        let along = (a * a - b * b + d * d) / (2.0 * d);
        let h = (a * a - along * along).max(0.0).sqrt();
        let s = lower(
            [1.0, -1.0].map(|sg| [along * u[0] + sg * h * w[0], along * u[1] + sg * h * w[1]]),
        );
        let q1 = s[1].atan2(s[0]);
        q[0] = q1;
        q[k] = wrap((start[1] - s[1]).atan2(start[0] - s[0]) - q1);
        return Ok(q);
    }
    let a: f64 = robot.lengths()[..k].iter().sum();
    let m = robot.lengths()[k];
    let b: f64 = robot.lengths()[k + 1..].iter().sum();
    if (a - b).abs() > 1e-9 * (a + b) {
        return Err(Error::InfeasibleTask(format!(
            "the start pose of an odd link count needs arms of equal length: {a:.3} m and {b:.3} m"
        )));
    }
    let c = (d - m) / (2.0 * a);
    if !(d > 0.0 && c.abs() <= 1.0) {
        return Err(Error::InfeasibleTask(format!(
            "no straight-arm pose puts the EE at ({:.3}, {:.3}), {d:.3} m from the grip: arms of \
             {a:.3} m joined by a middle link of {m:.3} m reach from {:.3} m to {:.3} m",
            start[0],
            start[1],
            (m - 2.0 * a).max(0.0),
            m + 2.0 * a
        )));
    }
    // end of the grip arm = a c u + h w (or - h w), the middle link from there along u
    let h = a * (1.0 - c * c).max(0.0).sqrt();
    let e =
        lower([1.0, -1.0].map(|sg| [a * c * u[0] + sg * h * w[0], a * c * u[1] + sg * h * w[1]]));
    let q1 = e[1].atan2(e[0]);
    let th_mid = u[1].atan2(u[0]);
    let f = [e[0] + m * u[0], e[1] + m * u[1]];
    q[0] = q1;
    q[k] = wrap(th_mid - q1);
    q[k + 1] = wrap((start[1] - f[1]).atan2(start[0] - f[0]) - th_mid);
    Ok(q)
}
