//! The parameters file of an imported robot, each number followed by the URDF elements it came
//! from.

use super::Imported;

/// A number written so that it parses back to the same f64 (Rust's shortest round-trip form).
fn num(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains('.') || s.contains('e') || s.contains("inf") || s.contains("NaN") {
        s
    } else {
        format!("{s}.0")
    }
}

/// The TOML text of `imp.params`, every number traced to its URDF element in a comment; `source`
/// names the URDF file in the header. It parses back to exactly `imp.params`.
pub fn imported_toml(imp: &Imported, source: &str) -> String {
    let p = &imp.params;
    let why = |field: &str| {
        imp.trace
            .iter()
            .find(|(f, _)| f == field)
            .map(|(_, s)| s.clone())
            .unwrap_or_default()
    };
    let mut head = format!(
        "# A brachia robot imported from {source} (brachia robot import).\n\
         # Units: m, kg, kg m^2, rad, rad/s, N m. Link frames: x along the link, y across it.\n\
         # The chain's URDF joints, grip first: {:?}.\n",
        imp.joints
    );
    head.push_str(&format!("name = {}\n", toml::Value::String(p.name.clone())));
    let mut out = head;
    let line = |field: &str, key: &str, value: String, out: &mut String| {
        let w = why(field);
        if w.is_empty() {
            out.push_str(&format!("{key} = {value}\n"));
        } else {
            out.push_str(&format!("{key} = {value}  # {w}\n"));
        }
    };
    line("gravity", "gravity", num(p.gravity), &mut out);
    if let Some([x, y]) = p.end_effector {
        line(
            "end_effector",
            "end_effector",
            format!("[{}, {}]", num(x), num(y)),
            &mut out,
        );
    }
    for (k, l) in p.links.iter().enumerate() {
        out.push_str(&format!(
            "\n[[links]]  # joint {} at its proximal end: URDF {:?}\n",
            k + 1,
            imp.joints.get(k).map(String::as_str).unwrap_or("")
        ));
        let f = |name: &str| format!("links[{k}].{name}");
        line(&f("length"), "length", num(l.length), &mut out);
        line(&f("mass"), "mass", num(l.mass), &mut out);
        line(&f("com"), "com", num(l.com), &mut out);
        if l.com_across != 0.0 {
            line(&f("com_across"), "com_across", num(l.com_across), &mut out);
        }
        line(&f("inertia"), "inertia", num(l.inertia), &mut out);
        out.push_str(&format!(
            "radius = {}  # capsule for collision checks (not read from the URDF)\n",
            num(l.radius)
        ));
        if l.joint_offset != 0.0 {
            line(
                &f("joint_offset"),
                "joint_offset",
                num(l.joint_offset),
                &mut out,
            );
        }
        if l.joint_reversed {
            out.push_str(
                "joint_reversed = true  # the joint's <axis> points against the chain's axis\n",
            );
        }
        for (name, v) in [("q_min", l.q_min), ("q_max", l.q_max), ("qd_max", l.qd_max)] {
            if let Some(v) = v {
                line(&f(name), name, num(v), &mut out);
            }
        }
    }
    out.push_str("\n[actuators]\n");
    let list = |v: &[f64]| {
        let items: Vec<String> = v.iter().map(|x| num(*x)).collect();
        format!("[{}]", items.join(", "))
    };
    let src: Vec<String> = (0..p.actuators.tau_max.len())
        .map(|j| why(&format!("actuators.tau_max[{j}]")))
        .collect();
    out.push_str(&format!("# per actuated joint: {}\n", src.join("; ")));
    out.push_str(&format!("tau_min = {}\n", list(&p.actuators.tau_min)));
    out.push_str(&format!("tau_max = {}\n", list(&p.actuators.tau_max)));
    out
}
