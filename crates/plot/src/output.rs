//! Rendering to memory and writing files atomically.
//!
//! A static figure is drawn twice through the same generic drawing code: into an RGB buffer (encoded as
//! PNG with the `png` crate) and into an SVG string. Both are written to hidden temporary files beside
//! their targets and only then renamed into place, so a failure never leaves a half-written figure.

use crate::error::PlotError;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::fmt::Display;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The bundled font (DejaVu Sans, Bitstream Vera licence: see `assets/DejaVuSans-LICENSE.txt`).
static FONT_BYTES: &[u8] = include_bytes!("../assets/DejaVuSans.ttf");

/// Register the bundled font as "sans-serif" once per process.
pub(crate) fn ensure_font() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        plotters::style::register_font("sans-serif", FontStyle::Normal, FONT_BYTES).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err("the bundled DejaVuSans.ttf could not be parsed".into())
    }
}

/// Convert any displayable error into the message string the drawing code passes around.
pub(crate) trait OrMsg<T> {
    /// `Err(e)` becomes `Err(e.to_string())`.
    fn msg(self) -> Result<T, String>;
}

impl<T, E: Display> OrMsg<T> for Result<T, E> {
    fn msg(self) -> Result<T, String> {
        self.map_err(|e| e.to_string())
    }
}

/// Something that can draw itself on any plotters backend (bitmap for PNG/GIF frames, SVG).
pub(crate) trait Drawable {
    /// Draw the whole picture on `root` (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Render into an RGB8 buffer of `size` pixels (row-major, 3 bytes per pixel).
pub(crate) fn render_rgb(size: (u32, u32), fig: &impl Drawable) -> Result<Vec<u8>, String> {
    ensure_font()?;
    let mut buf = vec![255u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut buf, size).into_drawing_area();
        root.fill(&WHITE).msg()?;
        fig.draw(&root)?;
        root.present().msg()?;
    }
    Ok(buf)
}

/// Render into an SVG document of `size` (user units = pixels).
pub(crate) fn render_svg(size: (u32, u32), fig: &impl Drawable) -> Result<String, String> {
    ensure_font()?;
    let mut s = String::new();
    {
        let root = SVGBackend::with_string(&mut s, size).into_drawing_area();
        root.fill(&WHITE).msg()?;
        fig.draw(&root)?;
        root.present().msg()?;
    }
    Ok(s)
}

/// Encode an RGB8 buffer as PNG bytes.
pub(crate) fn encode_png(rgb: &[u8], size: (u32, u32)) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(rgb.len() / 8);
    {
        let mut enc = png::Encoder::new(&mut out, size.0, size.1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().msg()?;
        w.write_image_data(rgb).msg()?;
        w.finish().msg()?;
    }
    Ok(out)
}

/// Check that `path` has a file name ending in `.ext` (case-insensitive).
pub(crate) fn check_extension(path: &Path, ext: &str) -> Result<(), PlotError> {
    let ok = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case(ext));
    if ok && path.file_name().is_some() {
        Ok(())
    } else {
        Err(PlotError::InvalidPath {
            path: path.to_path_buf(),
            reason: format!("expected a file name ending in .{ext}"),
        })
    }
}

/// Render a static figure and write `path` (PNG) and the same path with extension `.svg`.
pub(crate) fn write_static(
    path: &Path,
    size: (u32, u32),
    fig: &impl Drawable,
) -> Result<(), PlotError> {
    check_extension(path, "png")?;
    let render_err = |message: String| PlotError::Render {
        path: path.to_path_buf(),
        message,
    };
    let rgb = render_rgb(size, fig).map_err(render_err)?;
    let png = encode_png(&rgb, size).map_err(|message| PlotError::Encode {
        path: path.to_path_buf(),
        message,
    })?;
    let svg_path = path.with_extension("svg");
    let svg = render_svg(size, fig).map_err(|message| PlotError::Render {
        path: svg_path.clone(),
        message,
    })?;
    write_atomic(&[(path, png.as_slice()), (&svg_path, svg.as_bytes())])
}

/// Hidden temporary name beside `target`.
fn temp_name(target: &Path) -> PathBuf {
    let name = target
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    target.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// Write every `(target, bytes)` to a temporary file beside its target, then rename them all into
/// place. On any failure the temporary files are removed and no target is touched (a rename failing
/// halfway through the list can leave the earlier, complete files in place).
pub(crate) fn write_atomic(files: &[(&Path, &[u8])]) -> Result<(), PlotError> {
    let mut temps: Vec<PathBuf> = Vec::with_capacity(files.len());
    let cleanup = |temps: &[PathBuf]| {
        for t in temps {
            let _ = std::fs::remove_file(t);
        }
    };
    for (target, bytes) in files {
        let tmp = temp_name(target);
        if let Err(source) = std::fs::write(&tmp, bytes) {
            let _ = std::fs::remove_file(&tmp);
            cleanup(&temps);
            return Err(PlotError::Io {
                path: target.to_path_buf(),
                source,
            });
        }
        temps.push(tmp);
    }
    for (i, (target, _)) in files.iter().enumerate() {
        if let Err(source) = std::fs::rename(&temps[i], target) {
            cleanup(&temps[i..]);
            return Err(PlotError::Io {
                path: target.to_path_buf(),
                source,
            });
        }
    }
    Ok(())
}
