//! Every number of a URDF document checked on the text before the URDF parser reads it, so that a
//! refusal names the element, the link, joint or material it belongs to, the attribute, the value as
//! written and the rule. The URDF parser's own errors name none of these, and it reads a vector such
//! as `xyz="1 heavy 2 3"` as `1 2 3`, dropping the word.

use crate::{Error, Result};
use quick_xml::events::{BytesStart, Event};
use quick_xml::Reader;

/// The numeric attributes of the URDF elements brachia's parser reads: element, attribute, how
/// many numbers it holds, and whether the element needs it.
const NUMERIC: &[(&str, &str, usize, bool)] = &[
    ("origin", "xyz", 3, false),
    ("origin", "rpy", 3, false),
    ("origin", "quat_xyzw", 4, false),
    ("axis", "xyz", 3, false),
    ("mass", "value", 1, true),
    ("inertia", "ixx", 1, true),
    ("inertia", "ixy", 1, true),
    ("inertia", "ixz", 1, true),
    ("inertia", "iyy", 1, true),
    ("inertia", "iyz", 1, true),
    ("inertia", "izz", 1, true),
    ("limit", "lower", 1, false),
    ("limit", "upper", 1, false),
    ("limit", "effort", 1, false),
    ("limit", "velocity", 1, false),
    ("limit", "acceleration", 1, false),
    ("limit", "deceleration", 1, false),
    ("limit", "jerk", 1, false),
    ("dynamics", "damping", 1, false),
    ("dynamics", "friction", 1, false),
    ("safety_controller", "soft_lower_limit", 1, false),
    ("safety_controller", "soft_upper_limit", 1, false),
    ("safety_controller", "k_position", 1, false),
    ("safety_controller", "k_velocity", 1, false),
    ("mimic", "multiplier", 1, false),
    ("mimic", "offset", 1, false),
    ("calibration", "rising", 1, false),
    ("calibration", "falling", 1, false),
    ("box", "size", 3, false),
    ("cylinder", "radius", 1, false),
    ("cylinder", "length", 1, false),
    ("capsule", "radius", 1, false),
    ("capsule", "length", 1, false),
    ("sphere", "radius", 1, false),
    ("mesh", "scale", 3, false),
    ("color", "rgba", 4, false),
];

/// The elements of `<robot>` whose contents the URDF parser reads.
const READ: &[&str] = &["link", "joint", "material"];

/// The rule a numeric attribute of `count` numbers obeys.
fn rule(count: usize) -> String {
    if count == 1 {
        "must be one finite number".into()
    } else {
        format!("must be {count} finite numbers separated by spaces")
    }
}

/// Whether `text` is `count` finite numbers separated by white space.
fn numbers_ok(text: &str, count: usize) -> bool {
    let words: Vec<&str> = text.split_whitespace().collect();
    words.len() == count
        && words
            .iter()
            .all(|w| w.parse::<f64>().is_ok_and(|v| v.is_finite()))
}

/// Where an element sits: `link "arm"`, `joint "elbow"` or `material "red"`.
fn owner(e: &BytesStart) -> String {
    let kind = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
    let name = e
        .attributes()
        .flatten()
        .find(|a| a.key.as_ref() == b"name")
        .and_then(|a| a.unescape_value().ok().map(|v| v.into_owned()))
        .unwrap_or_default();
    format!("{kind} \"{name}\"")
}

/// Check the numeric attributes of one element inside `owner`.
fn check_element(e: &BytesStart, owner: &str, src: &str) -> Result<()> {
    let tag = String::from_utf8_lossy(e.local_name().as_ref()).into_owned();
    for &(_, attr, count, required) in NUMERIC.iter().filter(|(el, ..)| *el == tag) {
        let found = e
            .attributes()
            .flatten()
            .find(|a| a.key.as_ref() == attr.as_bytes());
        let field = format!("{owner} <{tag} {attr}>");
        match found {
            None if required => {
                return Err(Error::invalid(
                    src,
                    field,
                    "(missing)",
                    format!("<{tag}> needs it: {}", rule(count)),
                ))
            }
            None => {}
            Some(a) => {
                let value = a
                    .unescape_value()
                    .map(|v| v.into_owned())
                    .unwrap_or_else(|_| String::from_utf8_lossy(&a.value).into_owned());
                if !numbers_ok(&value, count) {
                    return Err(Error::invalid(
                        src,
                        field,
                        format!("{value:?}"),
                        rule(count),
                    ));
                }
            }
        }
    }
    Ok(())
}

/// Refuse a document with a numeric attribute that is not the finite numbers its element takes
/// (see the module docs). Malformed markup is left for the parser to refuse.
pub fn check_numbers(text: &str, src: &str) -> Result<()> {
    let mut reader = Reader::from_str(text);
    // element names from the root down, and the owner (link, joint, material) of the current one
    let mut depth = 0usize;
    let mut owner_at: Option<(usize, String)> = None;
    loop {
        let (e, empty) = match reader.read_event() {
            Ok(Event::Start(e)) => (e, false),
            Ok(Event::Empty(e)) => (e, true),
            Ok(Event::End(_)) => {
                depth = depth.saturating_sub(1);
                if owner_at.as_ref().is_some_and(|(d, _)| *d > depth) {
                    owner_at = None;
                }
                continue;
            }
            Ok(Event::Eof) | Err(_) => return Ok(()),
            Ok(_) => continue,
        };
        depth += 1;
        let local = e.local_name();
        let tag = local.as_ref();
        if depth == 2 && READ.iter().any(|r| r.as_bytes() == tag) {
            owner_at = Some((depth, owner(&e)));
        } else if let Some((_, o)) = &owner_at {
            check_element(&e, o, src)?;
        }
        if empty {
            depth -= 1;
            if owner_at.as_ref().is_some_and(|(d, _)| *d > depth) {
                owner_at = None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = r#"<robot name="r"><link name="arm"><inertial><origin xyz="0 0 -0.1"/>
        <mass value="MASS"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
        <joint name="elbow" type="revolute"><limit effort="EFFORT" velocity="1"/></joint>
        <gazebo><limit effort="not read"/></gazebo></robot>"#;

    fn with(mass: &str, effort: &str) -> Result<()> {
        check_numbers(
            &DOC.replace("MASS", mass).replace("EFFORT", effort),
            "r.urdf",
        )
    }

    #[test]
    fn numbers_are_checked_where_the_parser_reads_them() {
        with("1.5", "6").unwrap();
        with(" 2e-1 ", "6").unwrap();
        let e = with("heavy", "6").unwrap_err().to_string();
        assert!(
            e.contains("r.urdf") && e.contains("link \"arm\" <mass value>") && e.contains("heavy"),
            "{e}"
        );
        assert!(e.contains("one finite number"), "{e}");
        for bad in ["inf", "NaN", "1 2", ""] {
            assert!(with(bad, "6").is_err(), "{bad}");
        }
        let e = with("1", "-inf").unwrap_err().to_string();
        assert!(e.contains("joint \"elbow\" <limit effort>"), "{e}");
    }

    #[test]
    fn a_vector_with_a_word_in_it_is_refused() {
        let doc = DOC
            .replace("MASS", "1")
            .replace("EFFORT", "1")
            .replace("0 0 -0.1", "0 heavy 0 -0.1");
        let e = check_numbers(&doc, "r.urdf").unwrap_err().to_string();
        assert!(
            e.contains("link \"arm\" <origin xyz>") && e.contains("3 finite numbers"),
            "{e}"
        );
        let missing = DOC.replace("value=\"MASS\"", "").replace("EFFORT", "1");
        let e = check_numbers(&missing, "r.urdf").unwrap_err().to_string();
        assert!(e.contains("<mass value>") && e.contains("missing"), "{e}");
    }
}
