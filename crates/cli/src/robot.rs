//! `brachia robot import` and `brachia robot export`: robots from URDF files and to URDF or MuJoCo
//! MJCF (the library's `brachia::urdf`).

use crate::CliError;
use brachia::urdf::{import_urdf_file, imported_toml, to_mjcf, to_urdf, Tip, UrdfOptions};
use brachia::Robot;
use brachia_experiments::staging;
use std::path::{Path, PathBuf};

/// Arguments of `brachia robot`.
#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand)]
enum Command {
    /// Read the serial chain of a URDF file as a brachia parameters file (TOML), every number
    /// followed by the URDF elements it came from.
    Import(ImportArgs),
    /// Write a brachia robot as a URDF or MuJoCo MJCF file.
    Export(ExportArgs),
}

/// Arguments of `brachia robot import`.
#[derive(clap::Args)]
struct ImportArgs {
    /// The URDF file.
    urdf: PathBuf,
    /// The joint at the grip (passive): a revolute or continuous joint, or the fixed joint where
    /// the hand holds the bar.
    #[arg(long)]
    grip: String,
    /// The tip: a link, or a link and a point in its frame, `LINK:x,y,z` (m).
    #[arg(long)]
    tip: String,
    /// Joints without an actuator, comma-separated (when the file has no <transmission>).
    #[arg(long)]
    passive: Option<String>,
    /// Joints (or links) off the chain to leave out, comma-separated.
    #[arg(long)]
    ignore: Option<String>,
    /// Gravitational acceleration of the URDF world along -z, m/s^2.
    #[arg(long, default_value_t = 9.81)]
    gravity: f64,
    /// The parameters file to write.
    #[arg(long)]
    out: PathBuf,
    /// Overwrite --out if it exists.
    #[arg(long)]
    force: bool,
}

/// The export formats.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    /// URDF (Drake, pinocchio, rviz, ...).
    Urdf,
    /// MuJoCo MJCF.
    Mjcf,
}

/// Arguments of `brachia robot export`.
#[derive(clap::Args)]
struct ExportArgs {
    /// Robot parameters (TOML), e.g. params/paper.toml.
    #[arg(long)]
    params: PathBuf,
    /// The format to write.
    #[arg(long, value_enum)]
    format: Format,
    /// The file to write.
    #[arg(long)]
    out: PathBuf,
    /// Overwrite --out if it exists.
    #[arg(long)]
    force: bool,
}

/// Run the command.
pub fn run(a: Args) -> Result<(), CliError> {
    match a.command {
        Command::Import(a) => import(a),
        Command::Export(a) => export(a),
    }
}

fn list(text: &Option<String>) -> Vec<String> {
    text.as_deref()
        .map(|t| {
            t.split(',')
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty())
                .collect()
        })
        .unwrap_or_default()
}

/// Refuse, before any work: an existing `out` without --force, a folder (also spelt with a trailing
/// `/`), a symbolic link, a FIFO, socket or device, an `out` that is one of the files read (`inputs`,
/// also through a link: --force would replace the input), and an `out` whose folder does not exist.
fn check_out(out: &Path, force: bool, inputs: &[&Path]) -> Result<(), CliError> {
    let same = |input: &Path| match (out.canonicalize(), input.canonicalize()) {
        (Ok(o), Ok(i)) => o == i,
        _ => false,
    };
    if let Some(input) = inputs.iter().find(|i| same(i)) {
        return Err(CliError::Input(format!(
            "--out {}: is the input file {}; writing it would replace what is read (choose another \
             --out)",
            out.display(),
            input.display()
        )));
    }
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !parent.is_dir() {
        return Err(CliError::Input(format!(
            "--out {}: the folder {} does not exist (create it first)",
            out.display(),
            parent.display()
        )));
    }
    if out.as_os_str().to_string_lossy().ends_with('/') {
        return Err(CliError::Input(format!(
            "--out {}: ends with `/`, so it names a folder; the output is a file",
            out.display()
        )));
    }
    if let Ok(m) = std::fs::symlink_metadata(out) {
        if m.file_type().is_symlink() {
            return Err(CliError::Input(format!(
                "--out {}: is a symbolic link; brachia writes a regular file and never replaces a \
                 link (give the path of the file itself)",
                out.display()
            )));
        }
        if !m.is_file() && !m.is_dir() {
            return Err(CliError::Input(format!(
                "--out {}: is not a regular file (a FIFO, socket or device), which writing would \
                 replace",
                out.display()
            )));
        }
    }
    if out.exists() && !force {
        return Err(CliError::Input(format!(
            "--out {}: the file exists (pass --force to overwrite it)",
            out.display()
        )));
    }
    if out.is_dir() {
        return Err(CliError::Input(format!(
            "--out {}: is a folder, not a file",
            out.display()
        )));
    }
    Ok(())
}

/// Write `text` to `out` through a staging folder beside it (`.NAME.partial-PID-K`, locked while
/// this process lives, see `brachia_experiments::staging`): the file is written there and renamed
/// into place. Staging folders of `out` whose owner died are removed first; a live one is kept.
fn write(out: &Path, text: &str) -> Result<(), CliError> {
    let name = out
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let err = |e: std::io::Error| CliError::Io(format!("could not write {}: {e}", out.display()));
    let stage = staging::create_unique(parent, &format!(".{name}.partial-")).map_err(err)?;
    let tmp = stage.join(&name);
    let done = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .and_then(|mut f| std::io::Write::write_all(&mut f, text.as_bytes()))
        .and_then(|_| std::fs::rename(&tmp, out));
    staging::remove(&stage);
    done.map_err(err)
}

fn import(a: ImportArgs) -> Result<(), CliError> {
    let tip: Tip = a
        .tip
        .parse()
        .map_err(|e: String| CliError::Input(format!("--tip: {e}")))?;
    if !(a.gravity.is_finite() && a.gravity >= 0.0 && a.gravity <= brachia::limits::MAX_GRAVITY) {
        return Err(CliError::Input(format!(
            "--gravity = {}: must be in [0, {}] m/s^2",
            a.gravity,
            brachia::limits::MAX_GRAVITY
        )));
    }
    check_out(&a.out, a.force, &[&a.urdf])?;
    let opts = UrdfOptions {
        passive: list(&a.passive),
        ignore: list(&a.ignore),
        gravity: a.gravity,
        ..UrdfOptions::new(a.grip.clone(), tip)
    };
    let imp = import_urdf_file(&a.urdf, &opts)?;
    // the result must be a valid robot before it is written
    Robot::from_params(imp.params.clone(), &a.urdf.display().to_string())?;
    write(&a.out, &imported_toml(&imp, &a.urdf.display().to_string()))
}

fn export(a: ExportArgs) -> Result<(), CliError> {
    check_out(&a.out, a.force, &[&a.params])?;
    let robot = Robot::from_toml_file(&a.params)?;
    let text = match a.format {
        Format::Urdf => to_urdf(&robot)?,
        Format::Mjcf => to_mjcf(&robot),
    };
    write(&a.out, &text)
}
