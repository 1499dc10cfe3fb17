//! Regression (hostile-input sweep, F8): `brachia plan --out link4`, link4 a symbolic link to an empty
//! folder, ran the whole plan, failed to rename its staging folder into place (exit 3) and left the
//! complete `.link4.partial-PID-0/` behind; with `--force` and a link to a non-empty folder it replaced
//! the link by a real folder and moved the user's files out of the folder it pointed to. Now
//! `check_out_dir` refuses a symbolic link with or without `force`, `RunFolder::write` refuses it too
//! (for callers that skip the check), and a staging folder that cannot be renamed into place is removed.

use brachia_run::{check_out_dir, RunFolder};
use std::path::Path;

fn leftovers(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|f| f.contains(".partial") || f.contains(".old-"))
        .collect()
}

fn folder() -> RunFolder {
    let mut f = RunFolder::default();
    f.add("a.txt", "a\n");
    f.add("sub/b.txt", "b\n");
    f
}

#[test]
fn a_symbolic_link_as_out_is_refused_and_nothing_is_left_behind() {
    let dir = tempfile::tempdir().unwrap();
    let user = dir.path().join("userdir");
    std::fs::create_dir_all(&user).unwrap();
    std::fs::write(user.join("keep.txt"), "x").unwrap();
    let empty = dir.path().join("emptyd");
    std::fs::create_dir_all(&empty).unwrap();
    for (target, name) in [(&user, "link1"), (&empty, "link4")] {
        let link = dir.path().join(name);
        std::os::unix::fs::symlink(target, &link).unwrap();
        for force in [false, true] {
            let e = check_out_dir(&link, force).unwrap_err().to_string();
            assert!(e.contains("symbolic link"), "{e}");
        }
        let e = folder().write(&link).unwrap_err().to_string();
        assert!(e.contains("symbolic link"), "{e}");
        assert!(link.is_symlink());
    }
    assert_eq!(std::fs::read_to_string(user.join("keep.txt")).unwrap(), "x");
    assert_eq!(std::fs::read_dir(&user).unwrap().count(), 1);
    assert_eq!(std::fs::read_dir(&empty).unwrap().count(), 0);
    assert!(
        leftovers(dir.path()).is_empty(),
        "{:?}",
        leftovers(dir.path())
    );
}

#[test]
fn a_staging_folder_that_cannot_be_installed_is_removed() {
    let dir = tempfile::tempdir().unwrap();
    // --out became a regular file after it was checked: the rename cannot happen
    let out = dir.path().join("out");
    std::fs::write(&out, "mine").unwrap();
    assert!(folder().write(&out).is_err());
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "mine");
    assert!(
        leftovers(dir.path()).is_empty(),
        "{:?}",
        leftovers(dir.path())
    );
}
