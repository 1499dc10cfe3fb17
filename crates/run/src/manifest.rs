//! The manifest of a run folder ([`MANIFEST`], `.brachia-run`): the files a run wrote, each with its
//! size and CRC-32, so that a later run (or `brachia report`) removes or replaces only a file it can
//! prove brachia wrote: listed, inside the folder through real folders only (no `..`, no absolute path,
//! no symbolic link on the way), a regular file, and of the listed size and checksum. Any other file is
//! the user's and is kept.
//!
//! Format (schema [`MANIFEST_SCHEMA`]): a first line `# brachia run-folder manifest, schema 1`, then one
//! line per file: `SIZE CRC32 PATH` (decimal bytes, 8 hex digits, a path relative to the folder with `/`
//! between its parts). A manifest of an older brachia (a first line `# brachia run folder: ...` and bare
//! paths) is read as schema 0: its files are listed but never proven, so they are all kept.

use brachia::Error;
use std::collections::{BTreeMap, BTreeSet};
use std::io::Read;
use std::path::{Component, Path, PathBuf};

/// The manifest of a run folder. Its presence marks a folder as a brachia run folder.
pub const MANIFEST: &str = ".brachia-run";

/// The schema of the manifest this brachia writes.
pub const MANIFEST_SCHEMA: u32 = 1;

const HEADER_PREFIX: &str = "# brachia run-folder manifest, schema ";
/// First lines of the listings of older brachia versions (a run folder's, a results page's).
const OLD_HEADER_PREFIXES: [&str; 2] = ["# brachia run folder", "# figures written by brachia"];

/// Largest manifest read, bytes (a run writes a few hundred files at most).
const MAX_MANIFEST_BYTES: u64 = 4 << 20;

/// Size and CRC-32 of a file as brachia wrote it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Stamp {
    /// Bytes.
    pub size: u64,
    /// CRC-32 (IEEE) of the contents.
    pub crc: u32,
}

impl Stamp {
    /// The stamp of `data`.
    pub fn of(data: &[u8]) -> Self {
        Stamp {
            size: data.len() as u64,
            crc: crc32fast::hash(data),
        }
    }
}

/// A manifest read back: every listed path with its stamp (`None` in a schema-0 manifest).
#[derive(Debug, Clone, Default)]
pub struct Manifest {
    /// The listed files, relative to the folder.
    pub files: BTreeMap<PathBuf, Option<Stamp>>,
}

/// The manifest text listing `files` (relative paths) with their stamps.
pub fn manifest_text(files: &BTreeMap<PathBuf, Stamp>) -> String {
    let mut text = format!(
        "{HEADER_PREFIX}{MANIFEST_SCHEMA} (size crc32 path of every file this run wrote; a re-run \
         replaces only these)\n"
    );
    for (p, s) in files {
        text.push_str(&format!(
            "{} {:08x} {}\n",
            s.size,
            s.crc,
            p.to_string_lossy()
        ));
    }
    text
}

/// `rel` as a path that stays inside its folder: relative, made of plain names only (no `.`, `..`,
/// root or prefix), none empty. `None` otherwise.
pub fn inside_rel(rel: &str) -> Option<PathBuf> {
    let p = Path::new(rel);
    if rel.is_empty() || rel.contains('\0') {
        return None;
    }
    let mut out = PathBuf::new();
    for c in p.components() {
        match c {
            Component::Normal(n) => out.push(n),
            _ => return None,
        }
    }
    // `a/./b` is dropped to `a/b` by components(): refuse what is not written plainly
    (out.as_os_str() == p.as_os_str()).then_some(out)
}

/// Read the manifest of `dir`: `Ok(None)` when `dir` has none. Refused (an error naming the manifest,
/// the line, the value and the rule) when it is not a regular file, is too large, has a schema this
/// brachia does not know, or lists a path that leaves the folder.
pub fn read_manifest(dir: &Path) -> Result<Option<Manifest>, Error> {
    read_listing(dir, MANIFEST)
}

/// [`read_manifest`] of a listing of another name in `dir` (the same format).
pub fn read_listing(dir: &Path, name: &str) -> Result<Option<Manifest>, Error> {
    let path = dir.join(name);
    let file = path.display().to_string();
    let meta = match std::fs::symlink_metadata(&path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => {
            return Err(Error::invalid(
                &file,
                "(the file)",
                "unreadable",
                e.to_string(),
            ))
        }
    };
    if !meta.file_type().is_file() {
        return Err(Error::invalid(
            &file,
            "(the file)",
            "not a regular file",
            "a run folder's manifest is a regular file (not a link, folder or device)",
        ));
    }
    if meta.len() > MAX_MANIFEST_BYTES {
        return Err(Error::invalid(
            &file,
            "(the file)",
            meta.len(),
            format!("a manifest has at most {MAX_MANIFEST_BYTES} bytes"),
        ));
    }
    let text = std::fs::read_to_string(&path)
        .map_err(|e| Error::invalid(&file, "(the file)", "unreadable", e.to_string()))?;
    let mut lines = text.lines();
    let head = lines.next().unwrap_or("");
    let schema = if let Some(rest) = head.strip_prefix(HEADER_PREFIX) {
        let v = rest.split_whitespace().next().unwrap_or("");
        match v.parse::<u32>() {
            Ok(s) if s == MANIFEST_SCHEMA => s,
            _ => {
                return Err(Error::invalid(
                    &file,
                    "line 1, schema",
                    v,
                    format!(
                        "this brachia reads manifest schema {MANIFEST_SCHEMA} (and 0, of older \
                         versions); the folder was written by a newer brachia"
                    ),
                ))
            }
        }
    } else if OLD_HEADER_PREFIXES.iter().any(|h| head.starts_with(h)) {
        0
    } else {
        return Err(Error::invalid(
            &file,
            "line 1",
            head.chars().take(80).collect::<String>(),
            format!("a brachia manifest starts with `{HEADER_PREFIX}{MANIFEST_SCHEMA}`"),
        ));
    };
    let mut files: BTreeMap<PathBuf, Option<Stamp>> = BTreeMap::new();
    for (i, l) in lines.enumerate() {
        let line = i + 2;
        if l.is_empty() || l.starts_with('#') {
            continue;
        }
        let bad = |v: &str, rule: &str| Error::invalid(&file, format!("line {line}"), v, rule);
        let (stamp, rel) = if schema == 0 {
            (None, l)
        } else {
            let mut parts = l.splitn(3, ' ');
            let (Some(size), Some(crc), Some(rel)) = (parts.next(), parts.next(), parts.next())
            else {
                return Err(bad(l, "expected SIZE CRC32 PATH"));
            };
            let size = size
                .parse::<u64>()
                .map_err(|_| bad(size, "SIZE is a whole number of bytes"))?;
            let crc = u32::from_str_radix(crc, 16)
                .ok()
                .filter(|_| crc.len() == 8)
                .ok_or_else(|| bad(crc, "CRC32 is 8 hex digits"))?;
            (Some(Stamp { size, crc }), rel)
        };
        let Some(rel) = inside_rel(rel) else {
            return Err(bad(
                rel,
                "a listed file must be a plain path inside the folder (no `..`, `.`, absolute path \
                 or empty part)",
            ));
        };
        if rel == Path::new(name) {
            return Err(bad(
                &rel.to_string_lossy(),
                "a manifest does not list itself",
            ));
        }
        if files.contains_key(&rel) {
            return Err(bad(
                &rel.to_string_lossy(),
                "the path is listed twice (a manifest lists each file once)",
            ));
        }
        // a listed file cannot also be a folder holding another listed file
        let clash = rel
            .ancestors()
            .skip(1)
            .find(|a| files.contains_key(*a))
            .map(Path::to_path_buf)
            .or_else(|| {
                files
                    .range::<PathBuf, _>(rel.clone()..)
                    .map(|(p, _)| p)
                    .next()
                    .filter(|p| p.starts_with(&rel))
                    .cloned()
            });
        if let Some(other) = clash {
            return Err(bad(
                &rel.to_string_lossy(),
                &format!(
                    "the path collides with the listed {}: one is a folder of the other, so both \
                     cannot be files",
                    other.display()
                ),
            ));
        }
        files.insert(rel, stamp);
    }
    Ok(Some(Manifest { files }))
}

/// Whether `dir/rel` is a regular file reached through real folders only (no symbolic link on the way,
/// nor the file itself a link).
pub fn plain_file(dir: &Path, rel: &Path) -> bool {
    let mut cur = dir.to_path_buf();
    let parts: Vec<_> = rel.components().collect();
    for (k, c) in parts.iter().enumerate() {
        cur.push(c.as_os_str());
        let Ok(m) = std::fs::symlink_metadata(&cur) else {
            return false;
        };
        let last = k + 1 == parts.len();
        if (last && !m.file_type().is_file()) || (!last && !m.file_type().is_dir()) {
            return false;
        }
    }
    !parts.is_empty()
}

/// Whether `dir/rel` is a file brachia wrote as `stamp` says: a plain file ([`plain_file`]) of that
/// size and CRC-32.
pub fn proven(dir: &Path, rel: &Path, stamp: Option<Stamp>) -> bool {
    let Some(stamp) = stamp else {
        return false;
    };
    if !plain_file(dir, rel) {
        return false;
    }
    let path = dir.join(rel);
    let Ok(f) = std::fs::File::open(&path) else {
        return false;
    };
    if f.metadata().map(|m| m.len()).ok() != Some(stamp.size) {
        return false;
    }
    let mut data = Vec::new();
    if f.take(stamp.size + 1).read_to_end(&mut data).is_err() {
        return false;
    }
    Stamp::of(&data) == stamp
}

/// The files of `dir`'s manifest that brachia can prove it wrote ([`proven`]).
pub fn proven_files(dir: &Path, m: &Manifest) -> BTreeSet<PathBuf> {
    m.files
        .iter()
        .filter(|(rel, s)| proven(dir, rel, **s))
        .map(|(rel, _)| rel.clone())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_that_leave_the_folder_are_not_inside() {
        for bad in [
            "",
            "/etc/passwd",
            "../x",
            "figures/../../x",
            "./x",
            "a/./b",
            "a//b",
            "a/",
        ] {
            assert!(inside_rel(bad).is_none(), "{bad:?}");
        }
        assert_eq!(
            inside_rel("figures/a.png"),
            Some(PathBuf::from("figures/a.png"))
        );
    }

    #[test]
    fn a_manifest_round_trips_and_proves_only_unchanged_files() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("sub")).unwrap();
        std::fs::write(d.path().join("sub/a.csv"), b"t\n0\n").unwrap();
        std::fs::write(d.path().join("b.json"), b"{}\n").unwrap();
        let mut files = BTreeMap::new();
        files.insert(PathBuf::from("sub/a.csv"), Stamp::of(b"t\n0\n"));
        files.insert(PathBuf::from("b.json"), Stamp::of(b"{}\n"));
        std::fs::write(d.path().join(MANIFEST), manifest_text(&files)).unwrap();
        let m = read_manifest(d.path()).unwrap().unwrap();
        assert_eq!(m.files.len(), 2);
        assert_eq!(proven_files(d.path(), &m).len(), 2);
        // a file edited by the user is no longer brachia's
        std::fs::write(d.path().join("b.json"), b"{\"mine\": 1}\n").unwrap();
        let p = proven_files(d.path(), &m);
        assert_eq!(
            p.into_iter().collect::<Vec<_>>(),
            vec![PathBuf::from("sub/a.csv")]
        );
    }

    #[test]
    fn listing_a_path_twice_itself_or_under_a_listed_file_is_refused() {
        let head = format!("{HEADER_PREFIX}{MANIFEST_SCHEMA}\n");
        for (lines, words) in [
            ("1 00000000 a.csv\n1 00000000 a.csv\n", "listed twice"),
            (
                "1 00000000 a\n1 00000000 a/b.csv\n",
                "collides with the listed a",
            ),
            (
                "1 00000000 a/b.csv\n1 00000000 a\n",
                "collides with the listed a/b.csv",
            ),
            ("1 00000000 .brachia-run\n", "does not list itself"),
        ] {
            let d = tempfile::tempdir().unwrap();
            std::fs::write(d.path().join(MANIFEST), format!("{head}{lines}")).unwrap();
            let e = read_manifest(d.path()).unwrap_err().to_string();
            assert!(e.contains(words) && e.contains("line "), "{lines:?}: {e}");
        }
        // siblings whose names share a start are no clash
        let d = tempfile::tempdir().unwrap();
        let ok = format!("{head}1 00000000 a\n1 00000000 a.csv\n1 00000000 ab/c\n");
        std::fs::write(d.path().join(MANIFEST), ok).unwrap();
        assert_eq!(read_manifest(d.path()).unwrap().unwrap().files.len(), 3);
    }

    #[test]
    fn escaping_entries_and_unknown_schemas_are_refused() {
        let d = tempfile::tempdir().unwrap();
        let write = |t: &str| std::fs::write(d.path().join(MANIFEST), t).unwrap();
        write("# brachia run folder: old\nfigures/../../../elsewhere/X.txt\n");
        let e = read_manifest(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("figures/../../../elsewhere/X.txt") && e.contains("line 2"),
            "{e}"
        );
        write(&format!("{HEADER_PREFIX}1\n3 00000000 /etc/passwd\n"));
        assert!(read_manifest(d.path()).is_err());
        write(&format!("{HEADER_PREFIX}9\n"));
        let e = read_manifest(d.path()).unwrap_err().to_string();
        assert!(e.contains("schema") && e.contains('9'), "{e}");
        write("not a manifest\n");
        assert!(read_manifest(d.path()).is_err());
        // schema 0 lists files but proves none
        write("# brachia run folder: old\nb.json\n");
        std::fs::write(d.path().join("b.json"), b"{}\n").unwrap();
        let m = read_manifest(d.path()).unwrap().unwrap();
        assert!(proven_files(d.path(), &m).is_empty());
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_never_proven() {
        let d = tempfile::tempdir().unwrap();
        let outside = tempfile::tempdir().unwrap();
        std::fs::write(outside.path().join("x"), b"abc").unwrap();
        std::os::unix::fs::symlink(outside.path(), d.path().join("figures")).unwrap();
        std::os::unix::fs::symlink(outside.path().join("x"), d.path().join("y")).unwrap();
        let s = Some(Stamp::of(b"abc"));
        assert!(!proven(d.path(), Path::new("figures/x"), s));
        assert!(!proven(d.path(), Path::new("y"), s));
    }
}
