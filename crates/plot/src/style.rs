//! Colours, number formatting and axis-range helpers shared by every figure.

use plotters::style::RGBColor;

/// Font family every figure uses (the bundled DejaVu Sans, registered under this name).
pub(crate) const FONT: &str = "sans-serif";

/// Ten distinguishable line colours (the "category 10" palette), cycled by series colour index.
const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// Line colour number `i` (cycles after ten).
pub fn series_colour(i: usize) -> RGBColor {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// Linear interpolation through equally spaced colour anchors, `t` clamped to [0, 1].
fn ramp(anchors: &[(u8, u8, u8)], t: f64) -> RGBColor {
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let s = t * (anchors.len() - 1) as f64;
    let k = (s.floor() as usize).min(anchors.len() - 2);
    let f = s - k as f64;
    let (a, b) = (anchors[k], anchors[k + 1]);
    let mix = |x: u8, y: u8| (x as f64 + f * (y as f64 - x as f64)).round() as u8;
    RGBColor(mix(a.0, b.0), mix(a.1, b.1), mix(a.2, b.2))
}

/// Perceptually ordered colour map for heat maps (dark purple at 0 through teal to yellow at 1).
pub fn value_colour(t: f64) -> RGBColor {
    const ANCHORS: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    ramp(&ANCHORS, t)
}

/// Colour of time fraction `t` in [0, 1] on stick diagrams: light (start) fading to dark (end).
pub fn time_colour(t: f64) -> RGBColor {
    const ANCHORS: [(u8, u8, u8); 4] =
        [(175, 205, 235), (90, 150, 210), (30, 80, 160), (10, 25, 80)];
    ramp(&ANCHORS, t)
}

/// Relative luminance in [0, 1] (to choose black or white text on a filled cell).
pub(crate) fn luminance(c: RGBColor) -> f64 {
    (0.299 * c.0 as f64 + 0.587 * c.1 as f64 + 0.114 * c.2 as f64) / 255.0
}

/// A compact label for a number: about three significant digits, no trailing zeros, no "-0".
pub fn format_number(v: f64) -> String {
    if !v.is_finite() {
        return format!("{v}");
    }
    let a = v.abs();
    let s = if a == 0.0 {
        "0".to_string()
    } else if !(1e-3..1e5).contains(&a) {
        format!("{v:.2e}")
    } else {
        let decimals = if a >= 100.0 {
            0
        } else if a >= 10.0 {
            1
        } else if a >= 1.0 {
            2
        } else {
            (2 - a.log10().floor() as i32).clamp(0, 6) as usize
        };
        let s = format!("{v:.decimals$}");
        if s.contains('.') {
            s.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            s
        }
    };
    if s == "-0" {
        "0".into()
    } else {
        s
    }
}

/// The range `[lo, hi]` padded by `frac` of its width on each side; a degenerate range is widened
/// to a unit-scale interval around its value.
pub(crate) fn padded(lo: f64, hi: f64, frac: f64) -> (f64, f64) {
    let w = hi - lo;
    if w <= 1e-12 * (lo.abs() + hi.abs()).max(1e-300) || w == 0.0 {
        let d = (lo.abs() * 0.1).max(0.5);
        return (lo - d, hi + d);
    }
    (lo - frac * w, hi + frac * w)
}

/// Widen the data box `(x_lo, x_hi, y_lo, y_hi)` about its centre so that one metre takes the same
/// number of pixels along x and y on a plotting area of `px_w` x `px_h` pixels (equal axis scale).
pub fn equal_aspect(bounds: (f64, f64, f64, f64), px_w: u32, px_h: u32) -> (f64, f64, f64, f64) {
    let (x0, x1, y0, y1) = bounds;
    let (w, h) = ((x1 - x0).max(1e-9), (y1 - y0).max(1e-9));
    let (pw, ph) = (px_w.max(1) as f64, px_h.max(1) as f64);
    // metres per pixel needed along each axis; use the larger for both
    let s = (w / pw).max(h / ph);
    let (cx, cy) = (0.5 * (x0 + x1), 0.5 * (y0 + y1));
    let (hw, hh) = (0.5 * s * pw, 0.5 * s * ph);
    (cx - hw, cx + hw, cy - hh, cy + hh)
}

/// Minimum and maximum of finite values (None if there are none).
pub(crate) fn min_max(values: impl IntoIterator<Item = f64>) -> Option<(f64, f64)> {
    values.into_iter().fold(None, |acc, v| match acc {
        None => Some((v, v)),
        Some((a, b)) => Some((a.min(v), b.max(v))),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_are_compact() {
        assert_eq!(format_number(0.0), "0");
        assert_eq!(format_number(1.5), "1.5");
        assert_eq!(format_number(-2.0), "-2");
        assert_eq!(format_number(0.355), "0.355");
        assert_eq!(format_number(12.345), "12.3");
        assert_eq!(format_number(1234.4), "1234");
        assert_eq!(format_number(-0.0001), "-1.00e-4");
    }

    #[test]
    fn equal_aspect_gives_equal_metres_per_pixel_and_contains_data() {
        let b = (-0.3, 1.1, -1.2, 0.1);
        for (pw, ph) in [(600, 400), (300, 700), (500, 500)] {
            let (x0, x1, y0, y1) = equal_aspect(b, pw, ph);
            let sx = (x1 - x0) / pw as f64;
            let sy = (y1 - y0) / ph as f64;
            assert!((sx - sy).abs() < 1e-12 * sx, "{sx} vs {sy}");
            assert!(x0 <= b.0 && x1 >= b.1 && y0 <= b.2 && y1 >= b.3);
            // one axis is tight
            let tight_x = ((x1 - x0) - (b.1 - b.0)).abs() < 1e-12;
            let tight_y = ((y1 - y0) - (b.3 - b.2)).abs() < 1e-12;
            assert!(tight_x || tight_y);
        }
    }

    #[test]
    fn colour_maps_hit_their_ends() {
        assert_eq!(value_colour(0.0), RGBColor(68, 1, 84));
        assert_eq!(value_colour(1.0), RGBColor(253, 231, 37));
        assert_eq!(value_colour(f64::NAN), value_colour(0.0));
        assert!(luminance(time_colour(0.0)) > luminance(time_colour(1.0)));
    }
}
