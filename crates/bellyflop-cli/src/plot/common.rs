//! What the plots share: the embedded font, the colours, text styles and
//! tick labels, and the ranges of the axes.

use std::ops::Range;
use std::sync::Once;

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle};

/// Font family name the plots ask for (registered in [`fonts`]).
pub(super) const FONT: &str = "sans-serif";

// Colours.
pub(super) const SOLUTION: RGBColor = RGBColor(31, 90, 180);
pub(super) const OVERLAY: RGBColor = RGBColor(230, 120, 20);
pub(super) const FLAME: RGBColor = RGBColor(215, 38, 30);
pub(super) const BODY: RGBColor = RGBColor(40, 40, 40);
pub(super) const GROUND: RGBColor = RGBColor(120, 85, 50);
pub(super) const SWITCH: RGBColor = RGBColor(0, 140, 70);
pub(super) const GREY: RGBColor = RGBColor(130, 130, 130);
/// Mesh interval breaks.
pub(super) const BREAK: RGBColor = RGBColor(150, 110, 190);
pub(super) const REJECTED: RGBColor = RGBColor(200, 30, 30);

/// Register the embedded font once.
pub(super) fn fonts() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let faces = [
            (FontStyle::Normal, dejavu::sans::regular()),
            (FontStyle::Bold, dejavu::sans::bold()),
            (FontStyle::Italic, dejavu::sans::oblique()),
            (FontStyle::Oblique, dejavu::sans::oblique()),
        ];
        for (style, bytes) in faces {
            // The bytes are a valid TrueType font shipped by the crate.
            if register_font(FONT, style, bytes).is_err() {
                panic!("the embedded DejaVu Sans font does not load");
            }
        }
    });
}

/// A chart of two f64 axes (metres, seconds, plot units).
pub(super) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

pub(super) type Res<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

/// `lo..hi` padded by `pad` of its width on each side; a degenerate range
/// gets a width of its own.
pub(super) fn padded(lo: f64, hi: f64, pad: f64) -> Range<f64> {
    let w = hi - lo;
    let w = if w > 1e-9 * lo.abs().max(hi.abs()).max(1e-300) {
        w
    } else {
        lo.abs().max(1.0) * 0.1
    };
    (lo - pad * w)..(hi + pad * w)
}

pub(super) fn min_max(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        })
}

/// The bounds near the data in [lo, hi] (within half its span), and
/// [lo, hi] widened to show them.
pub(super) fn near_bounds<'a>(
    lo: &mut f64,
    hi: &mut f64,
    bounds: &[(f64, &'a str)],
) -> Vec<(f64, &'a str)> {
    let span = (*hi - *lo).max(1e-12);
    let shown: Vec<(f64, &str)> = bounds
        .iter()
        .copied()
        .filter(|(b, _)| *b > *lo - 0.5 * span && *b < *hi + 0.5 * span)
        .collect();
    for (b, _) in &shown {
        *lo = lo.min(*b);
        *hi = hi.max(*b);
    }
    shown
}

/// A time-history panel's chart: `label` over t ∈ `t_range` and the
/// values in [lo, hi] (padded), with its mesh drawn.
pub(super) fn history_chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, plotters::coord::Shift>,
    label: &str,
    t_range: Range<f64>,
    (lo, hi): (f64, f64),
) -> Result<Chart<'a, DB>, DrawingAreaErrorKind<DB::ErrorType>> {
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .margin_right(18)
        .x_label_area_size(40)
        .y_label_area_size(72)
        .caption(label, text(17.0))
        .build_cartesian_2d(t_range, padded(lo, hi, 0.07))?;
    chart
        .configure_mesh()
        .x_desc("t [s]")
        .x_label_formatter(&|v| tick(*v))
        .label_style(text(13.0))
        .axis_desc_style(text(14.0))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(218, 218, 218))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    Ok(chart)
}

/// A step in the 1-2-5 series near `span / count`.
pub(super) fn nice_step(span: f64, count: f64) -> f64 {
    let raw = span / count;
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag)
}

pub(super) fn text(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

/// `v` with `digits` decimals, without a minus sign on a rounded zero.
pub(super) fn fixed(v: f64, digits: usize) -> String {
    let s = format!("{v:.digits$}");
    if s.trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// A time for a label: no trailing zeros.
pub(super) fn fmt_time(t: f64) -> String {
    let s = format!("{t:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

/// A tick label: plain numbers, no float noise.
pub(super) fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        format!("{v:.1e}")
    } else {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        if s == "-0" {
            "0".into()
        } else {
            s.to_string()
        }
    }
}
