//! The plots of `solve --out DIR`, each as SVG and PNG (plotters):
//!
//! - `path`: the x–z path with the vehicle outline at regular times and the
//!   thrust vector, on equal axis scales, plus a zoom on the touchdown;
//! - `histories`: x, z, Vx, Vz, θ, w, m, T, δ against time, nodes marked;
//! - `convergence`: virtual control, scaled step, cost and trust radius per
//!   SCvx iteration.
//!
//! An optional second trajectory (a re-integration of the solution's
//! controls) is drawn dashed on `path` and `histories`.
//!
//! Text uses DejaVu Sans, embedded from the `dejavu` crate and registered
//! with plotters' `ab_glyph` font backend, so no system font is needed.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::Once;

use bellyflop::{Scenario, Solution, SolverSettings};
use plotters::coord::combinators::IntoLogRange;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle};

use crate::error::OutputError;
use crate::sample::Dense;

/// Font family name the plots ask for (registered in [`fonts`]).
pub(crate) const FONT: &str = "sans-serif";

/// Every plot: file stem and size in pixels.
pub const PLOTS: [(&str, (u32, u32)); 3] = [
    ("path", (1300, 1050)),
    ("histories", (1600, 1150)),
    ("convergence", (1300, 950)),
];

// Colours.
const SOLUTION: RGBColor = RGBColor(31, 90, 180);
const OVERLAY: RGBColor = RGBColor(230, 120, 20);
const FLAME: RGBColor = RGBColor(215, 38, 30);
const BODY: RGBColor = RGBColor(40, 40, 40);
const GROUND: RGBColor = RGBColor(120, 85, 50);
const SWITCH: RGBColor = RGBColor(0, 140, 70);
const GREY: RGBColor = RGBColor(130, 130, 130);
/// Mesh interval breaks.
const BREAK: RGBColor = RGBColor(150, 110, 190);
const REJECTED: RGBColor = RGBColor(200, 30, 30);

/// Everything the plots draw.
pub struct PlotData<'a> {
    pub scenario: &'a Scenario,
    pub settings: &'a SolverSettings,
    pub solution: &'a Solution,
    /// The solution's interpolants, densely sampled.
    pub dense: &'a Dense,
    /// The solution at its LGR nodes.
    pub nodes: Dense,
    /// A second trajectory drawn dashed (e.g. re-integrated), if any.
    pub overlay: Option<&'a Dense>,
    /// Times where the thrust crosses the middle of [T_min, T_max]
    /// (between nodes, linearly interpolated), with `true` for upward.
    pub switches: Vec<(f64, bool)>,
    /// The times of the mesh's inner interval breaks \[s\] (none on the
    /// global mesh).
    pub breaks_s: Vec<f64>,
}

impl<'a> PlotData<'a> {
    pub fn new(
        scenario: &'a Scenario,
        settings: &'a SolverSettings,
        solution: &'a Solution,
        dense: &'a Dense,
        overlay: Option<&'a Dense>,
    ) -> Self {
        let nodes = Dense::nodes_of(solution);
        let v = &scenario.vehicle;
        let mid = 0.5 * (v.min_thrust_n + v.max_thrust_n);
        let mut switches = Vec::new();
        if v.max_thrust_n > v.min_thrust_n {
            for k in 1..nodes.len() {
                let (a, b) = (nodes.thrust_n[k - 1] - mid, nodes.thrust_n[k] - mid);
                if (a < 0.0) != (b < 0.0) {
                    let (t0, t1) = (nodes.t_s[k - 1], nodes.t_s[k]);
                    switches.push((t0 + (t1 - t0) * a / (a - b), b > a));
                }
            }
        }
        let b = &solution.mesh.breaks_tau;
        let breaks_s = b
            .iter()
            .skip(1)
            .take(b.len().saturating_sub(2))
            .map(|tau| 0.5 * (tau + 1.0) * solution.tf_s)
            .collect();
        PlotData {
            scenario,
            settings,
            solution,
            dense,
            nodes,
            overlay,
            switches,
            breaks_s,
        }
    }

    fn title(&self) -> String {
        let method = match self.solution.method {
            bellyflop::Method::Direct => "direct method".to_string(),
            bellyflop::Method::Scvx => format!(
                "SCvx, {} formulation",
                self.solution.formulation_label(self.settings.formulation)
            ),
        };
        let mesh = match (self.solution.intervals, &self.solution.refinement) {
            (1, _) => String::new(),
            (m, Some(r)) => format!(" over {m} intervals (refined, {} passes)", r.passes.len()),
            (m, None) => format!(" over {m} intervals"),
        };
        format!(
            "{}: N = {}{mesh}, {method}, {}, t_f = {:.3} s, final mass {:.1} kg",
            self.scenario.name,
            self.solution.nodes,
            self.solution.status.as_str(),
            self.solution.tf_s,
            self.solution.final_mass_kg
        )
    }
}

/// Register the embedded font once.
pub(crate) fn fonts() {
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

pub(crate) type Res<DB> = Result<(), DrawingAreaErrorKind<<DB as DrawingBackend>::ErrorType>>;

pub(crate) fn plot_error(path: &Path, e: impl std::fmt::Display) -> OutputError {
    OutputError::plot(path, e)
}

/// Draw every plot as `DIR/NAME.svg` and `DIR/NAME.png`; return the paths.
pub fn render_all(dir: &Path, d: &PlotData) -> Result<Vec<PathBuf>, OutputError> {
    fonts();
    let mut written = Vec::new();
    macro_rules! both {
        ($stem:expr, $size:expr, $draw:ident) => {{
            let svg = dir.join(format!("{}.svg", $stem));
            {
                let root = SVGBackend::new(&svg, $size).into_drawing_area();
                $draw(&root, d)
                    .and_then(|()| root.present())
                    .map_err(|e| plot_error(&svg, e))?;
            }
            written.push(svg);
            let png = dir.join(format!("{}.png", $stem));
            {
                let root = BitMapBackend::new(&png, $size).into_drawing_area();
                $draw(&root, d)
                    .and_then(|()| root.present())
                    .map_err(|e| plot_error(&png, e))?;
            }
            written.push(png);
        }};
    }
    for (stem, size) in PLOTS {
        match stem {
            "path" => both!(stem, size, draw_path),
            "histories" => both!(stem, size, draw_histories),
            _ => both!(stem, size, draw_convergence),
        }
    }
    Ok(written)
}

// ---------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------

/// `lo..hi` padded by `pad` of its width on each side; a degenerate range
/// gets a width of its own.
fn padded(lo: f64, hi: f64, pad: f64) -> Range<f64> {
    let w = hi - lo;
    let w = if w > 1e-9 * lo.abs().max(hi.abs()).max(1e-300) {
        w
    } else {
        lo.abs().max(1.0) * 0.1
    };
    (lo - pad * w)..(hi + pad * w)
}

fn min_max(values: impl IntoIterator<Item = f64>) -> (f64, f64) {
    values
        .into_iter()
        .filter(|v| v.is_finite())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        })
}

/// Linear interpolation of a sampled column at time `t` (clamped).
fn at(t_s: &[f64], col: &[f64], t: f64) -> f64 {
    let i = t_s.partition_point(|&s| s < t);
    if i == 0 {
        return col[0];
    }
    if i >= t_s.len() {
        return col[col.len() - 1];
    }
    let (t0, t1) = (t_s[i - 1], t_s[i]);
    let w = if t1 > t0 { (t - t0) / (t1 - t0) } else { 1.0 };
    col[i - 1] + w * (col[i] - col[i - 1])
}

/// A step in the 1-2-5 series near `span / count`.
fn nice_step(span: f64, count: f64) -> f64 {
    let raw = span / count;
    let mag = 10f64.powf(raw.log10().floor());
    [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag)
}

fn text(size: f64) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

// ---------------------------------------------------------------------------
// (a) The x–z path with the vehicle and its thrust
// ---------------------------------------------------------------------------

/// The vehicle at one time, in the x–z plane.
struct Pose {
    cg: (f64, f64),
    /// Corners of the body rectangle (closed: first repeated).
    body: Vec<(f64, f64)>,
    /// Nose cap: a triangle on the top end, so the nose is told from the engine.
    nose: Vec<(f64, f64)>,
    /// Thrust line from the nozzle along the exhaust, length ∝ T.
    flame: [(f64, f64); 2],
}

/// The body axis (engine → nose) is (−sin θ, cos θ): the thrust force
/// T·(−sin(θ+δ), cos(θ+δ)) of the dynamics points along it when δ = 0. The
/// exhaust leaves the nozzle the opposite way, (sin(θ+δ), −cos(θ+δ)).
fn pose(v: &bellyflop::input::scenario::Vehicle, s: &Sample, flame_at_max_m: f64) -> Pose {
    let (x, z) = (s.x, s.z);
    let a = (-s.theta.sin(), s.theta.cos());
    let n = (a.1, -a.0);
    let r = v.radius_m;
    let engine = (x - v.cg_m * a.0, z - v.cg_m * a.1);
    let top = v.length_m - v.cg_m;
    let cap = (2.0 * r).min(0.3 * v.length_m);
    let shoulder = (x + (top - cap) * a.0, z + (top - cap) * a.1);
    let tip = (x + top * a.0, z + top * a.1);
    let corner = |p: (f64, f64), sign: f64| (p.0 + sign * r * n.0, p.1 + sign * r * n.1);
    let body = vec![
        corner(engine, 1.0),
        corner(shoulder, 1.0),
        corner(shoulder, -1.0),
        corner(engine, -1.0),
        corner(engine, 1.0),
    ];
    let nose = vec![corner(shoulder, 1.0), tip, corner(shoulder, -1.0)];
    let phi = s.theta + s.delta;
    let len = flame_at_max_m * (s.thrust / v.max_thrust_n).max(0.0);
    let flame = [
        engine,
        (engine.0 + len * phi.sin(), engine.1 - len * phi.cos()),
    ];
    Pose {
        cg: (x, z),
        body,
        nose,
        flame,
    }
}

/// The trajectory at one time.
struct Sample {
    t: f64,
    x: f64,
    z: f64,
    theta: f64,
    delta: f64,
    thrust: f64,
}

fn sample(d: &Dense, t: f64) -> Sample {
    Sample {
        t,
        x: at(&d.t_s, &d.x_m, t),
        z: at(&d.t_s, &d.z_m, t),
        theta: at(&d.t_s, &d.theta_rad, t),
        delta: at(&d.t_s, &d.delta_rad, t),
        thrust: at(&d.t_s, &d.thrust_n, t),
    }
}

/// Regular times 0, Δ, 2Δ, … and t_f (the last regular time is dropped if
/// it is within Δ/3 of t_f).
fn regular_times(t0: f64, tf: f64, step: f64) -> Vec<f64> {
    let mut ts = Vec::new();
    let mut k = (t0 / step).ceil();
    while k * step < tf - step / 3.0 {
        ts.push(k * step);
        k += 1.0;
    }
    ts.push(tf);
    ts
}

/// Ranges with equal metres per pixel on both axes that contain `bbox`,
/// for a plotting area of `px` pixels.
fn equal_ranges(bbox: (Range<f64>, Range<f64>), px: (u32, u32)) -> (Range<f64>, Range<f64>) {
    let (xr, zr) = bbox;
    let (w, h) = (px.0.max(1) as f64, px.1.max(1) as f64);
    let s = ((xr.end - xr.start) / w).max((zr.end - zr.start) / h);
    let (xc, zc) = (0.5 * (xr.start + xr.end), 0.5 * (zr.start + zr.end));
    (
        (xc - 0.5 * s * w)..(xc + 0.5 * s * w),
        (zc - 0.5 * s * h)..(zc + 0.5 * s * h),
    )
}

/// The part of segment p–q inside the box `xr` × `zr` (Liang–Barsky), if any.
fn clip_segment(
    p: (f64, f64),
    q: (f64, f64),
    xr: &Range<f64>,
    zr: &Range<f64>,
) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dz) = (q.0 - p.0, q.1 - p.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (den, num) in [
        (-dx, p.0 - xr.start),
        (dx, xr.end - p.0),
        (-dz, p.1 - zr.start),
        (dz, zr.end - p.1),
    ] {
        if den == 0.0 {
            if num < 0.0 {
                return None;
            }
        } else {
            let r = num / den;
            if den < 0.0 {
                t0 = t0.max(r);
            } else {
                t1 = t1.min(r);
            }
        }
    }
    (t0 <= t1).then_some((
        (p.0 + t0 * dx, p.1 + t0 * dz),
        (p.0 + t1 * dx, p.1 + t1 * dz),
    ))
}

/// The pieces of a polyline inside the box: plotters would squash points
/// outside the ranges onto the border instead of cutting the line there.
fn clip_polyline(points: &[(f64, f64)], xr: &Range<f64>, zr: &Range<f64>) -> Vec<Vec<(f64, f64)>> {
    let mut pieces: Vec<Vec<(f64, f64)>> = Vec::new();
    let mut open = false;
    for w in points.windows(2) {
        match clip_segment(w[0], w[1], xr, zr) {
            Some((a, b)) => {
                let continues = open && a == w[0];
                if !continues {
                    pieces.push(vec![a]);
                }
                pieces.last_mut().expect("a piece was pushed").push(b);
                open = b == w[1];
            }
            None => open = false,
        }
    }
    pieces
}

fn inside(q: &(f64, f64), xr: &Range<f64>, zr: &Range<f64>) -> bool {
    xr.contains(&q.0) && zr.contains(&q.1)
}

/// One panel of the path plot.
struct PathPanel<'a> {
    caption: String,
    /// Outline times (already decluttered).
    times: Vec<f64>,
    /// Data box to show (before equalizing the scales).
    bbox: (Range<f64>, Range<f64>),
    data: &'a PlotData<'a>,
    flame_at_max_m: f64,
    /// Altitude of the ground: the engine's at touchdown.
    ground_m: f64,
}

/// Drop outline times whose CG is closer than `min_gap_m` to the next kept
/// one (walking back from t_f, which is always kept), so that the slow end
/// of the descent does not pile outlines on top of each other.
fn declutter(d: &Dense, times: &[f64], min_gap_m: f64) -> Vec<f64> {
    let mut kept: Vec<f64> = Vec::new();
    let mut last: Option<(f64, f64)> = None;
    for &t in times.iter().rev() {
        let s = sample(d, t);
        if last.is_none_or(|(x, z)| (s.x - x).hypot(s.z - z) >= min_gap_m) {
            kept.push(t);
            last = Some((s.x, s.z));
        }
    }
    kept.reverse();
    kept
}

/// Panel geometry of the path plot, in pixels.
const PANEL_MARGIN: u32 = 14;
const PANEL_X_LABELS: u32 = 44;
const PANEL_Y_LABELS: u32 = 66;

fn draw_path<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &PlotData) -> Res<DB> {
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!("Flip and landing — {}", d.title()),
        (FONT, 22).into_font().style(FontStyle::Bold),
    )?;
    let v = &d.scenario.vehicle;
    let tf = d.solution.tf_s;
    let dense = d.dense;
    let flame_at_max_m = 0.8 * v.length_m;
    let last = sample(dense, tf);
    let ground_m = pose(v, &last, flame_at_max_m).flame[0].1;

    // Whole descent: outlines at regular times (about 12).
    let step = nice_step(tf, 12.0);
    let times = declutter(dense, &regular_times(0.0, tf, step), 0.3 * v.length_m);
    let mut xs: Vec<f64> = dense.x_m.clone();
    let mut zs: Vec<f64> = dense.z_m.clone();
    for &t in &times {
        let p = pose(v, &sample(dense, t), flame_at_max_m);
        for q in p.body.iter().chain(&p.nose).chain(&p.flame) {
            xs.push(q.0);
            zs.push(q.1);
        }
    }
    if let Some(o) = d.overlay {
        xs.extend(&o.x_m);
        zs.extend(&o.z_m);
    }
    let (x0, x1) = min_max(xs);
    let (_, z1) = min_max(zs);
    let z0 = ground_m - 0.04 * (z1 - ground_m);
    let full = PathPanel {
        caption: format!("whole descent, vehicle every {step} s"),
        times,
        // Room on the left for the time labels.
        bbox: (
            (x0 - 0.45 * (x1 - x0))..(x1 + 0.04 * (x1 - x0)),
            z0..z1 + 0.02 * (z1 - z0),
        ),
        data: d,
        flame_at_max_m,
        ground_m,
    };

    // Touchdown: the part of the descent where the CG is below about two
    // body lengths above its target.
    let z_target = d.scenario.terminal.z_m;
    let z_zoom = z_target + 2.0 * v.length_m;
    let t_zoom = dense
        .t_s
        .iter()
        .zip(&dense.z_m)
        .find(|(_, &z)| z < z_zoom)
        .map_or(0.0, |(t, _)| *t);
    let zoom_step = nice_step(tf - t_zoom, 8.0);
    let zoom_times = declutter(
        dense,
        &regular_times(t_zoom, tf, zoom_step),
        0.12 * v.length_m,
    );
    let half_width = 0.7 * v.length_m;
    let zoom = PathPanel {
        caption: format!(
            "touchdown: last {:.1} s, vehicle every {zoom_step} s",
            tf - t_zoom
        ),
        times: zoom_times,
        bbox: (
            (last.x - half_width)..(last.x + half_width),
            (ground_m - 0.08 * (z_zoom - ground_m))..(z_zoom + 0.6 * v.length_m),
        ),
        data: d,
        flame_at_max_m,
        ground_m,
    };

    // The whole descent gets the width that gives equal axis scales at full
    // height; the legend and summary a fixed column on the right; the zoom
    // the rest (its x range widens to keep the scales equal).
    let (w, h) = root.dim_in_pixel();
    let plot_h = h
        .saturating_sub(34 + 2 * PANEL_MARGIN + PANEL_X_LABELS)
        .max(1) as f64;
    let aspect = (full.bbox.0.end - full.bbox.0.start) / (full.bbox.1.end - full.bbox.1.start);
    let w_full =
        ((aspect * plot_h) as u32 + 2 * PANEL_MARGIN + PANEL_Y_LABELS).clamp(w / 6, 2 * w / 5);
    let w_info = 430.min(w / 3);
    let (left, rest) = root.split_horizontally(w_full);
    let (middle, info) = rest.split_horizontally(w - w_full - w_info);
    draw_path_panel(&left, &full)?;
    draw_path_panel(&middle, &zoom)?;
    draw_path_info(&info, d, flame_at_max_m, ground_m)
}

fn draw_path_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, p: &PathPanel) -> Res<DB> {
    let d = p.data;
    let v = &d.scenario.vehicle;
    let dense = d.dense;
    let area = area.titled(&p.caption, (FONT, 18))?;
    let build = |ranges: (Range<f64>, Range<f64>)| {
        ChartBuilder::on(&area)
            .margin(PANEL_MARGIN)
            .x_label_area_size(PANEL_X_LABELS)
            .y_label_area_size(PANEL_Y_LABELS)
            .build_cartesian_2d(ranges.0, ranges.1)
    };
    // Measure the plotting area, then set equal scales on both axes.
    let px = build(p.bbox.clone())?.plotting_area().dim_in_pixel();
    let (xr, zr) = equal_ranges(p.bbox.clone(), px);
    let mut chart = build((xr.clone(), zr.clone()))?;
    chart
        .configure_mesh()
        .x_desc("x, downrange [m]")
        .y_desc("z, altitude of the CG [m]")
        .label_style(text(14.0))
        .axis_desc_style(text(16.0))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(218, 218, 218))
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    let (px_x, _) = chart.plotting_area().get_pixel_range();

    // CG target altitude.
    let z_target = d.scenario.terminal.z_m;
    chart.draw_series(DashedLineSeries::new(
        vec![(xr.start, z_target), (xr.end, z_target)],
        6,
        5,
        GREY.stroke_width(1),
    ))?;

    // Vehicle outlines and thrust, in time order (later ones on top).
    let n_times = p.times.len();
    for (i, &t) in p.times.iter().enumerate() {
        let s = sample(dense, t);
        let pose = pose(v, &s, p.flame_at_max_m);
        let final_pose = i + 1 == n_times;
        // An outline that does not fit in the panel is left out (the zoom).
        if !pose
            .body
            .iter()
            .chain(&pose.nose)
            .all(|q| inside(q, &xr, &zr))
        {
            continue;
        }
        for piece in clip_polyline(&pose.flame, &xr, &zr) {
            chart.draw_series(std::iter::once(PathElement::new(
                piece,
                FLAME.stroke_width(4),
            )))?;
        }
        let fill = if final_pose { 0.8 } else { 0.6 };
        chart.draw_series(std::iter::once(Polygon::new(
            pose.body.clone(),
            RGBColor(200, 212, 230).mix(fill).filled(),
        )))?;
        chart.draw_series(std::iter::once(Polygon::new(
            pose.nose.clone(),
            BODY.mix(0.85).filled(),
        )))?;
        chart.draw_series(std::iter::once(PathElement::new(
            pose.body.clone(),
            BODY.stroke_width(if final_pose { 2 } else { 1 }),
        )))?;
        chart.draw_series(std::iter::once(Circle::new(pose.cg, 2, BODY.filled())))?;

        // Time label left of the outline, or right of it near the left edge.
        let body_px: Vec<(i32, i32)> = pose
            .body
            .iter()
            .chain(&pose.nose)
            .map(|q| chart.backend_coord(q))
            .collect();
        let cg_px = chart.backend_coord(&pose.cg);
        let left_px = body_px.iter().map(|q| q.0).min().unwrap_or(cg_px.0);
        let right_px = body_px.iter().map(|q| q.0).max().unwrap_or(cg_px.0);
        let label = if final_pose {
            format!("t_f = {} s", fmt_time(s.t))
        } else {
            format!("{} s", fmt_time(s.t))
        };
        let style = text(14.0).color(&BODY);
        let (x, style) = if left_px - 80 > px_x.start {
            (left_px - 6, style.pos(Pos::new(HPos::Right, VPos::Center)))
        } else {
            (right_px + 6, style.pos(Pos::new(HPos::Left, VPos::Center)))
        };
        chart.plotting_area().strip_coord_spec().draw(&Text::new(
            label,
            (
                x - px_x.start,
                cg_px.1 - chart.plotting_area().get_base_pixel().1,
            ),
            style,
        ))?;
    }

    // Ground: the engine's altitude at touchdown, drawn over the outlines so
    // that it hides the exhaust below it, under the paths.
    chart.draw_series(std::iter::once(Rectangle::new(
        [(xr.start, zr.start), (xr.end, p.ground_m)],
        RGBColor(222, 208, 190).filled(),
    )))?;
    chart.draw_series(std::iter::once(PathElement::new(
        vec![(xr.start, p.ground_m), (xr.end, p.ground_m)],
        GROUND.stroke_width(3),
    )))?;

    // CG path and the nodes, over the outlines.
    let xz = |d: &Dense| -> Vec<(f64, f64)> {
        d.x_m.iter().copied().zip(d.z_m.iter().copied()).collect()
    };
    for piece in clip_polyline(&xz(dense), &xr, &zr) {
        chart.draw_series(LineSeries::new(piece, SOLUTION.stroke_width(2)))?;
    }
    if let Some(o) = d.overlay {
        for piece in clip_polyline(&xz(o), &xr, &zr) {
            chart.draw_series(DashedLineSeries::new(piece, 8, 5, OVERLAY.stroke_width(2)))?;
        }
        if let Some(end) = xz(o).last().filter(|q| inside(q, &xr, &zr)) {
            chart.draw_series(std::iter::once(Cross::new(
                *end,
                6,
                OVERLAY.stroke_width(2),
            )))?;
        }
    }
    chart.draw_series(
        xz(&d.nodes)
            .into_iter()
            .filter(|q| inside(q, &xr, &zr))
            .map(|q| Circle::new(q, 3, SOLUTION.filled())),
    )?;

    // Thrust switches on the path; a label that would overlap the previous
    // one is left out (the summary lists every switch).
    let mut last_label_y: Option<i32> = None;
    for &(ts, up) in &d.switches {
        let s = sample(dense, ts);
        if !inside(&(s.x, s.z), &xr, &zr) {
            continue;
        }
        chart.draw_series(std::iter::once(TriangleMarker::new(
            (s.x, s.z),
            9,
            SWITCH.filled(),
        )))?;
        let what = if up {
            "T_min → T_max"
        } else {
            "T_max → T_min"
        };
        let at_px = chart.backend_coord(&(s.x, s.z));
        if last_label_y.is_some_and(|y| (y - at_px.1).abs() < 20) {
            continue;
        }
        last_label_y = Some(at_px.1);
        let base = chart.plotting_area().get_base_pixel();
        let style = text(15.0).color(&SWITCH);
        let mid = (px_x.start + px_x.end) / 2;
        let (dx, style) = if at_px.0 > mid {
            (-12, style.pos(Pos::new(HPos::Right, VPos::Center)))
        } else {
            (12, style.pos(Pos::new(HPos::Left, VPos::Center)))
        };
        chart.plotting_area().strip_coord_spec().draw(&Text::new(
            format!("{what}, t = {ts:.2} s"),
            (at_px.0 + dx - base.0, at_px.1 - base.1),
            style,
        ))?;
    }

    Ok(())
}

/// The legend and a summary of the trajectory, in the right-hand column.
fn draw_path_info<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &PlotData,
    flame_at_max_m: f64,
    ground_m: f64,
) -> Res<DB> {
    let v = &d.scenario.vehicle;
    let dense = d.dense;
    let area = &area.margin(40, 10, 10, 10);
    let line_h = 24;
    let mut y = 10;
    let head = (FONT, 17.0)
        .into_font()
        .style(FontStyle::Bold)
        .color(&BLACK);
    let body = text(15.0);
    area.draw(&Text::new("Legend", (0, y), head.clone()))?;
    y += line_h + 6;
    let glyph_x = 4;
    let text_x = 44;
    let entry = |y: i32, glyph: &dyn Fn(i32) -> Res<DB>, label: String| -> Res<DB> {
        glyph(y)?;
        area.draw(&Text::new(
            label,
            (text_x, y),
            body.clone().pos(Pos::new(HPos::Left, VPos::Center)),
        ))
    };
    let line = |color: RGBColor, width: u32| {
        move |y: i32| -> Res<DB> {
            area.draw(&PathElement::new(
                vec![(glyph_x, y), (glyph_x + 30, y)],
                color.stroke_width(width),
            ))
        }
    };
    entry(
        y,
        &line(SOLUTION, 2),
        "path of the centre of mass (CG)".into(),
    )?;
    y += line_h;
    entry(
        y,
        &|y| area.draw(&Circle::new((glyph_x + 15, y), 3, SOLUTION.filled())),
        format!("LGR nodes ({})", d.nodes.len()),
    )?;
    y += line_h;
    if d.overlay.is_some() {
        entry(
            y,
            &|y| {
                area.draw(&PathElement::new(
                    vec![(glyph_x, y), (glyph_x + 10, y)],
                    OVERLAY.stroke_width(2),
                ))?;
                area.draw(&PathElement::new(
                    vec![(glyph_x + 18, y), (glyph_x + 30, y)],
                    OVERLAY.stroke_width(2),
                ))
            },
            "re-integrated trajectory (dashed), × its end".into(),
        )?;
        y += line_h;
    }
    entry(
        y,
        &|y| {
            area.draw(&Rectangle::new(
                [(glyph_x, y - 5), (glyph_x + 24, y + 5)],
                RGBColor(200, 212, 230).filled(),
            ))?;
            area.draw(&Rectangle::new(
                [(glyph_x, y - 5), (glyph_x + 24, y + 5)],
                BODY.stroke_width(1),
            ))?;
            area.draw(&Polygon::new(
                vec![
                    (glyph_x + 24, y - 5),
                    (glyph_x + 32, y),
                    (glyph_x + 24, y + 5),
                ],
                BODY.filled(),
            ))
        },
        format!(
            "vehicle, {} m × {} m, nose dark; CG {} m",
            v.length_m,
            2.0 * v.radius_m,
            v.cg_m
        ),
    )?;
    y += line_h;
    area.draw(&Text::new(
        "above the engine, drawn at the CG point",
        (text_x, y),
        body.clone().pos(Pos::new(HPos::Left, VPos::Center)),
    ))?;
    y += line_h;
    entry(
        y,
        &line(FLAME, 4),
        format!("thrust along the nozzle, length ∝ T ({flame_at_max_m:.0} m"),
    )?;
    y += line_h;
    area.draw(&Text::new(
        format!(
            "at T_max = {:.0} kN; T_min = {:.0} kN)",
            v.max_thrust_n / 1e3,
            v.min_thrust_n / 1e3
        ),
        (text_x, y),
        body.clone().pos(Pos::new(HPos::Left, VPos::Center)),
    ))?;
    y += line_h;
    entry(
        y,
        &|y| area.draw(&TriangleMarker::new((glyph_x + 15, y), 9, SWITCH.filled())),
        "thrust switch".into(),
    )?;
    y += line_h;
    entry(
        y,
        &|y| {
            area.draw(&PathElement::new(
                vec![(glyph_x, y), (glyph_x + 12, y)],
                GREY.stroke_width(1),
            ))?;
            area.draw(&PathElement::new(
                vec![(glyph_x + 18, y), (glyph_x + 30, y)],
                GREY.stroke_width(1),
            ))
        },
        format!(
            "target altitude of the CG, z_f = {} m",
            tick(d.scenario.terminal.z_m)
        ),
    )?;
    y += line_h;
    entry(
        y,
        &line(GROUND, 3),
        format!("ground: engine at touchdown, z = {} m", tick(ground_m)),
    )?;
    y += 2 * line_h;

    // Summary.
    area.draw(&Text::new("Summary", (0, y), head))?;
    y += line_h + 6;
    let last = dense.len() - 1;
    let deg = |r: f64| r.to_degrees();
    let max_abs = |c: &[f64]| c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let theta0 = dense.theta_rad[0];
    let theta_f = d.scenario.terminal.theta_deg.to_radians();
    let flip_done = dense
        .t_s
        .iter()
        .zip(&dense.theta_rad)
        .find(|(_, th)| (*th - theta_f).abs() <= 0.05 * (theta0 - theta_f).abs())
        .map(|(t, _)| *t);
    let mut lines = vec![
        format!(
            "status {}, {} SCvx iterations",
            d.solution.status.as_str(),
            d.solution.iterations
        ),
        format!("t_f = {:.3} s", d.solution.tf_s),
        format!(
            "final mass {:.1} kg, fuel {:.1} kg",
            d.solution.final_mass_kg, d.solution.fuel_kg
        ),
    ];
    if let Some(t) = flip_done {
        lines.push(format!(
            "flip: θ {:.0}° → {:.0}° (within 5 %) by t = {:.2} s",
            deg(theta0),
            deg(theta_f),
            t
        ));
    }
    lines.push(format!(
        "θ from {:.1}° to {:.1}°",
        deg(dense
            .theta_rad
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min)),
        deg(dense
            .theta_rad
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max))
    ));
    for &(ts, up) in &d.switches {
        lines.push(format!(
            "thrust {} at t = {ts:.2} s",
            if up {
                "T_min → T_max"
            } else {
                "T_max → T_min"
            }
        ));
    }
    lines.push(format!(
        "max |δ| = {:.1}° (limit {}°), max |w| = {:.1}°/s",
        deg(max_abs(&dense.delta_rad)),
        v.max_gimbal_deg,
        deg(max_abs(&dense.pitch_rate_radps))
    ));
    lines.push(format!(
        "touchdown: x = {} m, z = {} m,",
        fixed(dense.x_m[last], 3),
        fixed(dense.z_m[last], 3)
    ));
    lines.push(format!(
        "  |V| = {} m/s, θ = {}°, w = {}°/s",
        fixed(dense.vx_mps[last].hypot(dense.vz_mps[last]), 3),
        fixed(deg(dense.theta_rad[last]), 3),
        fixed(deg(dense.pitch_rate_radps[last]), 3)
    ));
    if let Some(o) = d.overlay {
        let t = &d.scenario.terminal;
        let end = o.len() - 1;
        lines.push(format!(
            "re-integrated: misses by {} m, {} m/s,",
            fixed((o.x_m[end] - t.x_m).hypot(o.z_m[end] - t.z_m), 3),
            fixed(
                (o.vx_mps[end] - t.vx_mps).hypot(o.vz_mps[end] - t.vz_mps),
                3
            )
        ));
        lines.push(format!(
            "  θ by {}°, mass by {:+.1} kg",
            fixed(deg(o.theta_rad[end]) - t.theta_deg, 3),
            o.mass_kg[end] - d.solution.final_mass_kg
        ));
    }
    for l in lines {
        area.draw(&Text::new(
            l,
            (0, y),
            body.clone().pos(Pos::new(HPos::Left, VPos::Center)),
        ))?;
        y += line_h;
    }
    Ok(())
}

/// `v` with `digits` decimals, without a minus sign on a rounded zero.
fn fixed(v: f64, digits: usize) -> String {
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
fn fmt_time(t: f64) -> String {
    let s = format!("{t:.2}");
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

// ---------------------------------------------------------------------------
// (b) Time histories
// ---------------------------------------------------------------------------

/// One panel of the time histories: label with unit, value in plot units,
/// horizontal reference lines (bounds).
struct History {
    label: &'static str,
    value: fn(&Dense) -> Vec<f64>,
    bounds: Vec<(f64, &'static str)>,
    /// A remark drawn in the panel (`;` separates lines).
    note: Option<&'static str>,
}

fn scaled(col: &[f64], k: f64) -> Vec<f64> {
    col.iter().map(|v| v * k).collect()
}

fn draw_histories<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &PlotData) -> Res<DB> {
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!("Time histories — {}", d.title()),
        (FONT, 22).into_font().style(FontStyle::Bold),
    )?;
    let v = &d.scenario.vehicle;
    let panels = [
        History {
            label: "x, downrange [m]",
            value: |d| d.x_m.clone(),
            bounds: vec![],
            note: None,
        },
        History {
            label: "z, altitude [m]",
            value: |d| d.z_m.clone(),
            bounds: vec![],
            note: None,
        },
        History {
            label: "Vx [m/s]",
            value: |d| d.vx_mps.clone(),
            bounds: vec![],
            note: None,
        },
        History {
            label: "Vz [m/s]",
            value: |d| d.vz_mps.clone(),
            bounds: vec![],
            note: None,
        },
        History {
            label: "θ, pitch from vertical [deg]",
            value: |d| scaled(&d.theta_rad, 180.0 / std::f64::consts::PI),
            bounds: vec![],
            note: None,
        },
        History {
            label: "w, pitch rate [deg/s]",
            value: |d| scaled(&d.pitch_rate_radps, 180.0 / std::f64::consts::PI),
            bounds: vec![],
            note: None,
        },
        History {
            label: "m, mass [kg]",
            value: |d| d.mass_kg.clone(),
            bounds: vec![(v.dry_mass_kg, "m_dry")],
            note: None,
        },
        History {
            label: "T, thrust [kN]",
            value: |d| scaled(&d.thrust_n, 1e-3),
            bounds: vec![
                (v.min_thrust_n * 1e-3, "T_min"),
                (v.max_thrust_n * 1e-3, "T_max"),
            ],
            note: Some("line: control polynomial; bounds are imposed at the nodes"),
        },
        History {
            label: "δ, nozzle angle [deg]",
            value: |d| scaled(&d.delta_rad, 180.0 / std::f64::consts::PI),
            bounds: vec![(-v.max_gimbal_deg, "−δ_max"), (v.max_gimbal_deg, "δ_max")],
            note: None,
        },
    ];
    let areas = root.split_evenly((3, 3));
    for (i, (area, h)) in areas.iter().zip(&panels).enumerate() {
        draw_history(area, d, h, i == 0)?;
    }
    Ok(())
}

fn draw_history<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &PlotData,
    h: &History,
    legend: bool,
) -> Res<DB> {
    let tf = d.solution.tf_s;
    let y = (h.value)(d.dense);
    let y_nodes = (h.value)(&d.nodes);
    let y_over = d.overlay.map(|o| (h.value)(o));
    let (mut lo, mut hi) = min_max(
        y.iter()
            .chain(&y_nodes)
            .chain(y_over.iter().flatten())
            .copied(),
    );
    // Show a bound when it is near the data (within half the data span).
    let span = (hi - lo).max(1e-12);
    let shown: Vec<(f64, &str)> = h
        .bounds
        .iter()
        .copied()
        .filter(|(b, _)| *b > lo - 0.5 * span && *b < hi + 0.5 * span)
        .collect();
    for (b, _) in &shown {
        lo = lo.min(*b);
        hi = hi.max(*b);
    }
    let t_range = 0.0..tf * 1.02;
    let mut chart = ChartBuilder::on(area)
        .margin(10)
        .margin_right(18)
        .x_label_area_size(40)
        .y_label_area_size(72)
        .caption(h.label, text(17.0))
        .build_cartesian_2d(t_range.clone(), padded(lo, hi, 0.07))?;
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

    // Mesh interval breaks: a thin solid line in every panel.
    for &tb in &d.breaks_s {
        let yr = chart.y_range();
        chart.draw_series(LineSeries::new(
            vec![(tb, yr.start), (tb, yr.end)],
            BREAK.stroke_width(1),
        ))?;
    }
    // Thrust switches: a vertical line in every panel.
    for &(ts, _) in &d.switches {
        let yr = chart.y_range();
        chart.draw_series(DashedLineSeries::new(
            vec![(ts, yr.start), (ts, yr.end)],
            6,
            4,
            SWITCH.stroke_width(1),
        ))?;
    }
    for (b, name) in &shown {
        chart.draw_series(DashedLineSeries::new(
            vec![(0.0, *b), (t_range.end, *b)],
            6,
            4,
            GREY.stroke_width(1),
        ))?;
        chart.draw_series(std::iter::once(
            EmptyElement::at((t_range.end, *b))
                + Text::new(name.to_string(), (-48, -16), text(12.0).color(&GREY)),
        ))?;
    }
    chart
        .draw_series(LineSeries::new(
            d.dense.t_s.iter().copied().zip(y.iter().copied()),
            SOLUTION.stroke_width(2),
        ))?
        .label("LGR interpolant")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], SOLUTION.stroke_width(2)));
    chart
        .draw_series(
            d.nodes
                .t_s
                .iter()
                .zip(&y_nodes)
                .map(|(&t, &v)| Circle::new((t, v), 3, SOLUTION.filled())),
        )?
        .label("LGR nodes")
        .legend(|(x, y)| Circle::new((x + 11, y), 3, SOLUTION.filled()));
    if let (Some(o), Some(yo)) = (d.overlay, &y_over) {
        chart
            .draw_series(DashedLineSeries::new(
                o.t_s.iter().copied().zip(yo.iter().copied()),
                8,
                5,
                OVERLAY.stroke_width(2),
            ))?
            .label("re-integrated (dashed)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], OVERLAY.stroke_width(2)));
    }
    if let Some(note) = h.note {
        let (xr, yr) = (chart.x_range(), chart.y_range());
        // Upper left, one line per `;`-separated part: clear of the bounds
        // and, for a thrust that starts low, of the data.
        for (i, part) in note.split(';').enumerate() {
            chart.draw_series(std::iter::once(
                EmptyElement::at((xr.start, yr.start + 0.7 * (yr.end - yr.start)))
                    + Text::new(
                        part.trim().to_string(),
                        (8, 16 * i as i32),
                        text(12.0)
                            .color(&GREY)
                            .pos(Pos::new(HPos::Left, VPos::Center)),
                    ),
            ))?;
        }
    }
    if legend {
        if !d.breaks_s.is_empty() {
            chart
                .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
                .label("mesh interval break")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], BREAK.stroke_width(1))
                });
        }
        if !d.switches.is_empty() {
            chart
                .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
                .label("thrust switch")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 22, y)], SWITCH.stroke_width(1))
                });
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(text(12.0))
            .background_style(WHITE.mix(0.9))
            .border_style(GREY)
            .draw()?;
    }
    Ok(())
}

/// A tick label: plain numbers, no float noise.
fn tick(v: f64) -> String {
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

// ---------------------------------------------------------------------------
// (c) Convergence
// ---------------------------------------------------------------------------

/// One convergence panel.
struct Convergence {
    caption: &'static str,
    values: Vec<f64>,
    /// A tolerance drawn as a horizontal line.
    tolerance: Option<(f64, &'static str)>,
    /// Log scale when every value is positive (or always, clamping).
    log: LogScale,
}

/// The iterations the panels share: their numbers and whether each step
/// was accepted (SCvx) or a regular step (the direct method: false marks a
/// restoration step).
struct Iterations {
    x: Vec<f64>,
    accepted: Vec<bool>,
    /// Axis name, and the marker names of accepted and other steps.
    axis: &'static str,
    names: (&'static str, &'static str),
}

#[derive(Clone, Copy, PartialEq)]
enum LogScale {
    /// Log scale; values ≤ 0 are drawn at the floor (marked).
    Always,
    /// Log scale if every value is positive, else linear.
    IfPositive,
}

fn draw_convergence<DB: DrawingBackend>(root: &DrawingArea<DB, Shift>, d: &PlotData) -> Res<DB> {
    root.fill(&WHITE)?;
    let (title, iterations, panels) = match d.solution.method {
        bellyflop::Method::Scvx => scvx_panels(d),
        bellyflop::Method::Direct => direct_panels(d),
    };
    let root = root.titled(
        &format!("{title} — {}", d.title()),
        (FONT, 22).into_font().style(FontStyle::Bold),
    )?;
    let areas = root.split_evenly((2, 2));
    for (i, (area, c)) in areas.iter().zip(&panels).enumerate() {
        draw_convergence_panel(area, &iterations, c, i == 0)?;
    }
    Ok(())
}

/// Virtual control, step, cost and trust radius per SCvx iteration.
fn scvx_panels(d: &PlotData) -> (&'static str, Iterations, [Convergence; 4]) {
    let sv = d.settings;
    let h = &d.solution.history;
    let values = |f: fn(&bellyflop::solution::IterationRecord) -> f64| h.iter().map(f).collect();
    let iterations = Iterations {
        x: h.iter().map(|r| r.iteration as f64).collect(),
        accepted: h.iter().map(|r| r.accepted).collect(),
        axis: "SCvx iteration",
        names: ("accepted step", "rejected step"),
    };
    let panels = [
        Convergence {
            caption: "virtual control, max |ν| (scaled)",
            values: values(|r| r.virtual_control),
            tolerance: Some((sv.virtual_control_tolerance, "tolerance")),
            log: LogScale::Always,
        },
        Convergence {
            caption: "step, max |Δz| (scaled)",
            values: values(|r| r.step),
            tolerance: Some((sv.step_tolerance, "tolerance")),
            log: LogScale::Always,
        },
        Convergence {
            caption: "cost J, penalized (scaled)",
            values: values(|r| r.cost),
            tolerance: None,
            log: LogScale::IfPositive,
        },
        Convergence {
            caption: "trust-region radius (scaled)",
            values: values(|r| r.trust_radius),
            tolerance: Some((sv.trust_region_min, "minimum")),
            log: LogScale::Always,
        },
    ];
    ("SCvx convergence", iterations, panels)
}

/// Primal and dual infeasibility, μ and the step length per interior-point
/// iteration.
fn direct_panels(d: &PlotData) -> (&'static str, Iterations, [Convergence; 4]) {
    let tol = d.settings.direct.tolerance;
    let h = &d.solution.direct_history;
    let values =
        |f: fn(&bellyflop::method::direct::DirectIteration) -> f64| h.iter().map(f).collect();
    let iterations = Iterations {
        x: h.iter().map(|r| r.iteration as f64).collect(),
        accepted: h.iter().map(|r| !r.restoration).collect(),
        axis: "interior-point iteration",
        names: ("Newton step", "restoration step"),
    };
    let panels = [
        Convergence {
            caption: "primal infeasibility, max |defect| (scaled)",
            values: values(|r| r.primal_infeasibility),
            tolerance: Some((tol, "tolerance")),
            log: LogScale::Always,
        },
        Convergence {
            caption: "dual infeasibility, max |∇L| (scaled)",
            values: values(|r| r.dual_infeasibility),
            tolerance: Some((tol, "tolerance")),
            log: LogScale::Always,
        },
        Convergence {
            caption: "barrier parameter μ",
            values: values(|r| r.mu),
            tolerance: None,
            log: LogScale::Always,
        },
        Convergence {
            caption: "step length α",
            values: values(|r| r.step),
            tolerance: None,
            log: LogScale::Always,
        },
    ];
    ("Interior-point convergence", iterations, panels)
}

fn draw_convergence_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    its: &Iterations,
    c: &Convergence,
    legend: bool,
) -> Res<DB> {
    let raw = &c.values;
    let all_positive = raw.iter().all(|v| *v > 0.0 && v.is_finite());
    let log = c.log == LogScale::Always || all_positive;
    let n = its.x.len().max(1) as f64;
    let x_range = 0.5..n + 0.5;
    let iter_x = |i: usize| its.x.get(i).copied().unwrap_or(i as f64 + 1.0);

    if log {
        // Clamp values ≤ 0 (or tiny) to a floor under the smallest positive one.
        let (pmin, pmax) = min_max(raw.iter().copied().filter(|v| *v > 0.0));
        let tol = c.tolerance.map(|t| t.0);
        let (pmin, pmax) = if pmin.is_finite() {
            (pmin.min(tol.unwrap_or(pmin)), pmax.max(tol.unwrap_or(pmax)))
        } else {
            let t = tol.unwrap_or(1.0);
            (t, t)
        };
        let floor = (pmin / 10.0).max(1e-300);
        let vals: Vec<(f64, bool)> = raw
            .iter()
            .map(|&v| if v > floor { (v, false) } else { (floor, true) })
            .collect();
        let lo = 10f64.powf((floor.log10() - 0.3).floor());
        let hi = 10f64.powf((pmax.log10() + 0.3).ceil());
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .margin_right(20)
            .x_label_area_size(42)
            .y_label_area_size(72)
            .caption(c.caption, text(17.0))
            .build_cartesian_2d(x_range, (lo..hi).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(its.axis)
            .y_desc("dimensionless, log scale")
            .label_style(text(13.0))
            .axis_desc_style(text(14.0))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(218, 218, 218))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| format!("{v:.0e}"))
            .draw()?;
        if let Some((t, name)) = c.tolerance {
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(0.5, t), (n + 0.5, t)],
                    6,
                    4,
                    GREY.stroke_width(1),
                ))?
                .label(name)
                .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], GREY.stroke_width(1)));
        }
        let pts: Vec<(f64, f64)> = vals
            .iter()
            .enumerate()
            .map(|(i, (v, _))| (iter_x(i), *v))
            .collect();
        chart.draw_series(LineSeries::new(pts.clone(), SOLUTION.stroke_width(1)))?;
        draw_markers(&mut chart, its, &pts, legend)?;
        let clamped: Vec<(f64, f64)> = vals
            .iter()
            .enumerate()
            .filter(|(_, (_, c))| *c)
            .map(|(i, (v, _))| (iter_x(i), *v))
            .collect();
        if !clamped.is_empty() {
            chart
                .draw_series(
                    clamped
                        .iter()
                        .map(|&p| TriangleMarker::new(p, 6, GREY.filled())),
                )?
                .label(format!("≤ {floor:.0e} (clamped)"))
                .legend(|(x, y)| TriangleMarker::new((x + 11, y), 6, GREY.filled()));
        }
        finish_legend(
            &mut chart,
            legend || !clamped.is_empty() || c.tolerance.is_some(),
        )?;
    } else {
        let (lo, hi) = min_max(raw.iter().copied());
        let mut chart = ChartBuilder::on(area)
            .margin(12)
            .margin_right(20)
            .x_label_area_size(42)
            .y_label_area_size(72)
            .caption(c.caption, text(17.0))
            .build_cartesian_2d(x_range, padded(lo, hi, 0.07))?;
        chart
            .configure_mesh()
            .x_desc(its.axis)
            .label_style(text(13.0))
            .axis_desc_style(text(14.0))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(218, 218, 218))
            .x_label_formatter(&|v| format!("{v:.0}"))
            .y_label_formatter(&|v| tick(*v))
            .draw()?;
        let pts: Vec<(f64, f64)> = raw
            .iter()
            .enumerate()
            .map(|(i, v)| (iter_x(i), *v))
            .collect();
        chart.draw_series(LineSeries::new(pts.clone(), SOLUTION.stroke_width(1)))?;
        draw_markers(&mut chart, its, &pts, legend)?;
        finish_legend(&mut chart, legend)?;
    }
    Ok(())
}

/// Accepted (regular) iterations as filled circles, the others as red crosses.
fn draw_markers<'a, DB: DrawingBackend + 'a, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    its: &Iterations,
    pts: &[(f64, f64)],
    legend: bool,
) -> Res<DB>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let acc = chart.draw_series(
        pts.iter()
            .zip(&its.accepted)
            .filter(|(_, a)| **a)
            .map(|(&p, _)| Circle::new(p, 4, SOLUTION.filled())),
    )?;
    if legend {
        acc.label(its.names.0)
            .legend(|(x, y)| Circle::new((x + 11, y), 4, SOLUTION.filled()));
    }
    let rej = chart.draw_series(
        pts.iter()
            .zip(&its.accepted)
            .filter(|(_, a)| !**a)
            .map(|(&p, _)| Cross::new(p, 5, REJECTED.stroke_width(2))),
    )?;
    if legend {
        rej.label(its.names.1)
            .legend(|(x, y)| Cross::new((x + 11, y), 5, REJECTED.stroke_width(2)));
    }
    Ok(())
}

fn finish_legend<'a, DB: DrawingBackend + 'a, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    show: bool,
) -> Res<DB>
where
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    if show {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(text(13.0))
            .background_style(WHITE.mix(0.9))
            .border_style(GREY)
            .draw()?;
    }
    Ok(())
}
