//! Every plot of `solve --out`, each as SVG and PNG.

use std::path::{Path, PathBuf};

use plotters::prelude::*;

use super::common::fonts;
use super::convergence::draw_convergence;
use super::data::PlotData;
use super::histories::draw_histories;
use super::path::draw_path;
use crate::error::OutputError;
use crate::files::commit;

/// Every plot: file stem and size in pixels.
pub const PLOTS: [(&str, (u32, u32)); 3] = [
    ("path", (1300, 1050)),
    ("histories", (1600, 1150)),
    ("convergence", (1300, 950)),
];

/// Draw `$draw(&root, $data)` as `$dir/$stem.svg` and `$dir/$stem.png` of
/// `$size` pixels, each written whole or not at all
/// ([`commit`]), and push both paths onto `$written` (the 6-DoF plots
/// use it too).
macro_rules! svg_and_png {
    ($dir:expr, $written:expr, $stem:expr, $size:expr, $draw:ident, $data:expr) => {{
        let svg = $dir.join(format!("{}.svg", $stem));
        commit(&svg, |tmp| {
            let root = SVGBackend::new(tmp, $size).into_drawing_area();
            $draw(&root, $data)
                .and_then(|()| root.present())
                .map_err(|e| OutputError::plot(&svg, e))
        })?;
        $written.push(svg);
        let png = $dir.join(format!("{}.png", $stem));
        commit(&png, |tmp| {
            let root = BitMapBackend::new(tmp, $size).into_drawing_area();
            $draw(&root, $data)
                .and_then(|()| root.present())
                .map_err(|e| OutputError::plot(&png, e))
        })?;
        $written.push(png);
    }};
}
pub(super) use svg_and_png;

/// Draw every plot as `DIR/NAME.svg` and `DIR/NAME.png`; return the paths.
pub fn render_all(dir: &Path, d: &PlotData) -> Result<Vec<PathBuf>, OutputError> {
    fonts();
    let mut written = Vec::new();
    for (stem, size) in PLOTS {
        match stem {
            "path" => svg_and_png!(dir, written, stem, size, draw_path, d),
            "histories" => svg_and_png!(dir, written, stem, size, draw_histories, d),
            _ => svg_and_png!(dir, written, stem, size, draw_convergence, d),
        }
    }
    Ok(written)
}
