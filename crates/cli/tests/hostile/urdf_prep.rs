//! Preparations of the URDF cases (`tests/hostile/urdf.txt`): robot files no edit of the base file
//! can make.

use std::fmt::Write as _;
use std::path::Path;

/// A chain of `n` revolute joints (each link 0.1 m, 0.1 kg), from `world` to `l{n}`.
fn chain(n: usize) -> String {
    let mut s =
        String::from("<?xml version=\"1.0\"?>\n<robot name=\"chain\">\n<link name=\"world\"/>\n");
    for k in 1..=n {
        let parent = if k == 1 {
            "world".to_string()
        } else {
            format!("l{}", k - 1)
        };
        let _ = write!(
            s,
            "<joint name=\"j{k}\" type=\"revolute\"><origin xyz=\"0 0 -0.1\"/><parent link=\"{parent}\"/>\
             <child link=\"l{k}\"/><axis xyz=\"0 1 0\"/><limit lower=\"-3\" upper=\"3\" effort=\"5\" \
             velocity=\"10\"/></joint>\n<link name=\"l{k}\"><inertial><origin xyz=\"0 0 -0.05\"/>\
             <mass value=\"0.1\"/><inertia ixx=\"0.001\" ixy=\"0\" ixz=\"0\" iyy=\"0.001\" iyz=\"0\" \
             izz=\"0.001\"/></inertial></link>\n"
        );
    }
    s.push_str("</robot>\n");
    s
}

/// Prepare the URDF case `name` at `u` (the case's `{U}`) in the case folder `t`; false for a name
/// that is not a URDF preparation.
pub fn prepare(name: &str, u: &Path, t: &Path) -> bool {
    let write = |text: &str| std::fs::write(u, text).unwrap();
    match name {
        // a chain of N links (100 000: far more than 12, and a file of megabytes)
        other if other.starts_with("urdfchain:") => {
            let n: usize = other["urdfchain:".len()..].parse().expect("urdfchain:N");
            write(&chain(n));
        }
        // l2 is the parent of l1 and l1 of l2: a cycle
        "urdfcycle" => {
            let mut s = chain(3);
            s = s.replace("</robot>\n", "");
            s.push_str(
                "<joint name=\"back\" type=\"revolute\"><parent link=\"l3\"/><child link=\"l1\"/>\
                 <axis xyz=\"0 1 0\"/><limit effort=\"5\" velocity=\"10\"/></joint>\n</robot>\n",
            );
            write(&s);
        }
        // a link that is its own child
        "urdfselfloop" => {
            let s = chain(3).replace(
                "</robot>\n",
                "<joint name=\"self\" type=\"fixed\"><parent link=\"l2\"/><child link=\"l2\"/></joint>\n</robot>\n",
            );
            write(&s);
        }
        // elements nested 140 000 deep (under the size cap)
        "urdfdeep" => {
            let mut s = String::from("<?xml version=\"1.0\"?>\n<robot name=\"deep\">");
            s.push_str(&"<a>".repeat(140_000));
            s.push_str(&"</a>".repeat(140_000));
            s.push_str("</robot>\n");
            write(&s);
        }
        // entities that expand exponentially (a billion laughs)
        "urdflaughs" => {
            let mut s =
                String::from("<?xml version=\"1.0\"?>\n<!DOCTYPE robot [\n<!ENTITY l0 \"ha\">\n");
            for k in 1..10 {
                let prev = format!("&l{};", k - 1).repeat(10);
                let _ = writeln!(s, "<!ENTITY l{k} \"{prev}\">");
            }
            s.push_str("]>\n<robot name=\"&l9;\"><link name=\"world\"/></robot>\n");
            write(&s);
        }
        "urdfdir" => {
            std::fs::remove_file(u).unwrap();
            std::fs::create_dir(u).unwrap();
        }
        "urdfdevzero" => {
            std::fs::remove_file(u).unwrap();
            std::os::unix::fs::symlink("/dev/zero", u).unwrap();
        }
        "urdfloop" => {
            std::fs::remove_file(u).unwrap();
            std::os::unix::fs::symlink(u, u).unwrap();
        }
        "urdfdangling" => {
            std::fs::remove_file(u).unwrap();
            std::os::unix::fs::symlink(t.join("nowhere.urdf"), u).unwrap();
        }
        // a sparse file of 1 GB
        "urdfhuge" => {
            let f = std::fs::File::create(u).unwrap();
            f.set_len(1 << 30).unwrap();
        }
        "urdfbinary" => std::fs::write(u, [0xff, 0xfe, 0x00, b'<', 0x80]).unwrap(),
        "urdffifo" => {
            std::fs::remove_file(u).unwrap();
            let ok = std::process::Command::new("mkfifo")
                .arg(u)
                .status()
                .unwrap()
                .success();
            assert!(ok, "mkfifo");
        }
        // a link to the robot parameters file (the case's `{P}`)
        "paramslink" => {
            std::os::unix::fs::symlink(t.join("robot.toml"), t.join("link.toml")).unwrap()
        }
        _ => return false,
    }
    true
}
