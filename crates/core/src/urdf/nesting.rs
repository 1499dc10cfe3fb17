//! A bound on how deeply the elements of a URDF document nest, checked on the text before any XML
//! parser sees it: a URDF nests a handful of levels (`robot > link > inertial > origin`), while a
//! file of a hundred thousand nested elements (well under the size cap) made the parsers run for
//! minutes.

use crate::{Error, Result};

/// The deepest element nesting a URDF document may have (checked on the text before it is parsed).
/// A URDF needs 4 levels, `<gazebo>` extensions a few more.
pub const MAX_URDF_DEPTH: usize = 64;

/// Refuse a document whose root element is not `<robot>` or whose elements nest deeper than
/// [`MAX_URDF_DEPTH`], naming the line. Comments, processing instructions, CDATA and the document type declaration are
/// skipped; quoted attribute values may hold `>`. Malformed markup is left for the parser to refuse.
pub fn check_nesting(text: &str, src: &str) -> Result<()> {
    let b = text.as_bytes();
    let find = |from: usize, pat: &[u8]| {
        b[from.min(b.len())..]
            .windows(pat.len())
            .position(|w| w == pat)
            .map(|p| from + p + pat.len())
    };
    let (mut i, mut depth, mut root_seen) = (0usize, 0usize, false);
    while i < b.len() {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &b[i..];
        i = if rest.starts_with(b"<!--") {
            find(i + 4, b"-->")
        } else if rest.starts_with(b"<![CDATA[") {
            find(i + 9, b"]]>")
        } else if rest.starts_with(b"<?") {
            find(i + 2, b"?>")
        } else if rest.starts_with(b"<!") {
            // a declaration, with an internal subset in brackets
            let mut k = i + 2;
            let mut brackets = 0i32;
            while k < b.len() && !(b[k] == b'>' && brackets <= 0) {
                match b[k] {
                    b'[' => brackets += 1,
                    b']' => brackets -= 1,
                    _ => {}
                }
                k += 1;
            }
            Some(k + 1)
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            find(i + 2, b">")
        } else {
            // an opening tag: to its `>` outside quotes; `/>` closes it at once
            let mut k = i + 1;
            let mut quote = None;
            while k < b.len() {
                match (quote, b[k]) {
                    (None, b'"' | b'\'') => quote = Some(b[k]),
                    (Some(q), c) if c == q => quote = None,
                    (None, b'>') => break,
                    _ => {}
                }
                k += 1;
            }
            if !root_seen {
                root_seen = true;
                let name: String = text[i + 1..k.min(b.len())]
                    .chars()
                    .take_while(|c| !c.is_whitespace() && *c != '/' && *c != '>')
                    .collect();
                if name != "robot" {
                    let line = 1 + b[..i].iter().filter(|&&c| c == b'\n').count();
                    return Err(Error::invalid(
                        src,
                        format!("line {line}"),
                        format!("<{name}>"),
                        "a URDF document's root element is <robot>",
                    ));
                }
            }
            if k < b.len() && b[k - 1] != b'/' {
                depth += 1;
                if depth > MAX_URDF_DEPTH {
                    let line = 1 + b[..i].iter().filter(|&&c| c == b'\n').count();
                    return Err(Error::invalid(
                        src,
                        format!("line {line}"),
                        format!("elements nested {depth} deep"),
                        format!(
                            "a URDF document may nest its elements at most {MAX_URDF_DEPTH} deep \
                             (brachia::urdf::MAX_URDF_DEPTH)"
                        ),
                    ));
                }
            }
            Some(k + 1)
        }
        .unwrap_or(b.len());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_deeply_nested_document_is_refused_and_a_urdf_passes() {
        let deep = format!("<robot>{}{}</robot>", "<a>".repeat(100), "</a>".repeat(100));
        let e = check_nesting("<robot_x></robot_x>", "r.urdf")
            .unwrap_err()
            .to_string();
        assert!(e.contains("<robot_x>"), "{e}");
        let e = check_nesting(&deep, "x.urdf").unwrap_err().to_string();
        assert!(e.contains("x.urdf") && e.contains("65 deep"), "{e}");
        let ok = "<?xml version=\"1.0\"?>\n<!-- <a><a><a> -->\n<!DOCTYPE r [<!ENTITY e \"x\">]>\n\
                  <robot name=\"a>b\"><link name=\"l\"><inertial><mass value=\"1\"/></inertial></link></robot>";
        check_nesting(ok, "ok.urdf").unwrap();
        // 64 levels pass, 65 do not
        let edge = format!("<robot>{}{}</robot>", "<a>".repeat(63), "</a>".repeat(63));
        check_nesting(&edge, "e.urdf").unwrap();
        let over = format!(
            "<robot>{}<a/>{}</robot>",
            "<a>".repeat(64),
            "</a>".repeat(64)
        );
        assert!(check_nesting(&over, "o.urdf").is_err());
    }
}
