//! (a) The x–z path with the vehicle and its thrust, on equal axis scales,
//! beside a zoom on the touchdown and the legend.

use std::ops::Range;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;

use super::common::{
    fmt_time, min_max, nice_step, text, tick, Chart, Res, BODY, FLAME, FONT, GREY, GROUND, OVERLAY,
    SOLUTION, SWITCH,
};
use super::data::PlotData;
use super::legend::draw_path_info;
use super::pose::{clip_polyline, equal_ranges, inside, pose, regular_times, sample};
use crate::sample::Dense;

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

pub(super) fn draw_path<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &PlotData,
) -> Res<DB> {
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
        draw_outline(&mut chart, p, (&xr, &zr), t, i + 1 == n_times)?;
    }
    draw_ground_and_paths(&mut chart, p, (&xr, &zr))?;
    draw_switches(&mut chart, d, (&xr, &zr))
}

/// The x and z ranges a panel shows.
type View<'r> = (&'r Range<f64>, &'r Range<f64>);

/// The vehicle at time `t`: its thrust, body, nose, CG and time label (left
/// out if the outline does not fit in the panel, as in the zoom).
fn draw_outline<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &PathPanel,
    (xr, zr): View,
    t: f64,
    final_pose: bool,
) -> Res<DB> {
    let v = &p.data.scenario.vehicle;
    let (px_x, _) = chart.plotting_area().get_pixel_range();
    let s = sample(p.data.dense, t);
    let pose = pose(v, &s, p.flame_at_max_m);
    // An outline that does not fit in the panel is left out (the zoom).
    if !pose
        .body
        .iter()
        .chain(&pose.nose)
        .all(|q| inside(q, xr, zr))
    {
        return Ok(());
    }
    for piece in clip_polyline(&pose.flame, xr, zr) {
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
    Ok(())
}

/// The ground, then the CG paths and the nodes over the outlines.
fn draw_ground_and_paths<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    p: &PathPanel,
    (xr, zr): View,
) -> Res<DB> {
    let d = p.data;
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
    for piece in clip_polyline(&xz(d.dense), xr, zr) {
        chart.draw_series(LineSeries::new(piece, SOLUTION.stroke_width(2)))?;
    }
    if let Some(o) = d.overlay {
        for piece in clip_polyline(&xz(o), xr, zr) {
            chart.draw_series(DashedLineSeries::new(piece, 8, 5, OVERLAY.stroke_width(2)))?;
        }
        if let Some(end) = xz(o).last().filter(|q| inside(q, xr, zr)) {
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
            .filter(|q| inside(q, xr, zr))
            .map(|q| Circle::new(q, 3, SOLUTION.filled())),
    )?;
    Ok(())
}

/// The thrust switches on the path, with their labels.
fn draw_switches<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    d: &PlotData,
    (xr, zr): View,
) -> Res<DB> {
    let (px_x, _) = chart.plotting_area().get_pixel_range();
    // Thrust switches on the path; a label that would overlap the previous
    // one is left out (the summary lists every switch).
    let mut last_label_y: Option<i32> = None;
    for &(ts, up) in &d.switches {
        let s = sample(d.dense, ts);
        if !inside(&(s.x, s.z), xr, zr) {
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
