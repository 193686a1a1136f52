//! The 6-DoF path: the x–z and y–z side views and the x–y top view of the
//! centre of mass, each on equal axis scales, with the vehicle's axis at
//! regular nodes, and a summary.

use std::ops::Range;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::SixDofPlot;
use crate::plot::common::{min_max, text, tick, Res, BODY, FLAME, FONT, GREY, GROUND, SOLUTION};
use crate::plot::pose::{clip_polyline, equal_ranges, inside};
use bellyflop::problem::six_dof::sx;

/// Points between two nodes on the Hermite interpolant of the path.
const SAMPLES: usize = 10;

/// About how many nodes show the vehicle's axis.
const AXES_SHOWN: usize = 12;

/// One view: its caption, axis names and the two coordinates it shows
/// (indices into (x, y, z)).
struct View {
    caption: &'static str,
    x_desc: &'static str,
    y_desc: &'static str,
    axes: (usize, usize),
    /// Whether the vertical coordinate is the altitude (the ground drawn).
    side: bool,
}

const VIEWS: [View; 3] = [
    View {
        caption: "side view x–z",
        x_desc: "x, downrange [m]",
        y_desc: "z, altitude of the CG [m]",
        axes: (0, 2),
        side: true,
    },
    View {
        caption: "side view y–z",
        x_desc: "y, crossrange [m]",
        y_desc: "z, altitude of the CG [m]",
        axes: (1, 2),
        side: true,
    },
    View {
        caption: "top view x–y",
        x_desc: "x, downrange [m]",
        y_desc: "y, crossrange [m]",
        axes: (0, 1),
        side: false,
    },
];

/// The path of the CG: the cubic Hermite interpolant of (r, V) between the
/// nodes, `SAMPLES` points per interval, as (x, y, z).
fn dense_path(d: &SixDofPlot) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for (k, pair) in d.states.windows(2).enumerate() {
        let h = d.t_s[k + 1] - d.t_s[k];
        let (a, b) = (&pair[0], &pair[1]);
        for j in 0..SAMPLES {
            let s = j as f64 / SAMPLES as f64;
            let (h00, h10) = (
                2.0 * s.powi(3) - 3.0 * s * s + 1.0,
                s.powi(3) - 2.0 * s * s + s,
            );
            let (h01, h11) = (-2.0 * s.powi(3) + 3.0 * s * s, s.powi(3) - s * s);
            out.push(std::array::from_fn(|i| {
                h00 * a[sx::X + i]
                    + h10 * h * a[sx::VX + i]
                    + h01 * b[sx::X + i]
                    + h11 * h * b[sx::VX + i]
            }));
        }
    }
    if let Some(last) = d.states.last() {
        out.push([last[sx::X], last[sx::Y], last[sx::Z]]);
    }
    out
}

/// The vehicle's axis at node `k`: engine and nose, as (x, y, z).
fn axis_line(d: &SixDofPlot, axis: [f64; 3], k: usize) -> [[f64; 3]; 2] {
    let v = &d.scenario.vehicle;
    let s = &d.states[k];
    let at = |l: f64| std::array::from_fn(|i| s[sx::X + i] + l * axis[i]);
    [at(-v.cg_m), at(v.length_m - v.cg_m)]
}

pub(super) fn draw_path<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &SixDofPlot,
) -> Res<DB> {
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!("Flip and landing, 6-DoF — {}", d.title()),
        (FONT, 22).into_font().style(FontStyle::Bold),
    )?;
    let path = dense_path(d);
    let axes = d.axes();
    let step = (d.states.len() / AXES_SHOWN).max(1);
    let mut shown: Vec<usize> = (0..d.states.len()).step_by(step).collect();
    if let Some(last) = d.states.len().checked_sub(1) {
        if shown.last() != Some(&last) {
            shown.push(last);
        }
    }
    let lines: Vec<[[f64; 3]; 2]> = shown.iter().map(|&k| axis_line(d, axes[k], k)).collect();
    let areas = root.split_evenly((2, 2));
    for (area, view) in areas.iter().zip(&VIEWS) {
        draw_view(area, d, view, &path, &lines)?;
    }
    match areas.get(3) {
        Some(info) => draw_info(info, d),
        None => Ok(()),
    }
}

/// One view: the ground or the pad, the axes, the path, the nodes.
fn draw_view<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &SixDofPlot,
    view: &View,
    path: &[[f64; 3]],
    lines: &[[[f64; 3]; 2]],
) -> Res<DB> {
    let (i, j) = view.axes;
    let flat = |p: &[f64; 3]| (p[i], p[j]);
    let (x0, x1) = min_max(
        path.iter()
            .map(|p| p[i])
            .chain(lines.iter().flatten().map(|p| p[i])),
    );
    let (y0, y1) = min_max(
        path.iter()
            .map(|p| p[j])
            .chain(lines.iter().flatten().map(|p| p[j])),
    );
    let pad = 0.05 * (x1 - x0).max(y1 - y0).max(1.0);
    let bbox = ((x0 - pad)..(x1 + pad), (y0 - pad)..(y1 + pad));
    let area = area.titled(view.caption, (FONT, 18))?;
    let build = |ranges: (Range<f64>, Range<f64>)| {
        ChartBuilder::on(&area)
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(66)
            .build_cartesian_2d(ranges.0, ranges.1)
    };
    // Measure the plotting area, then set equal scales on both axes.
    let px = build(bbox.clone())?.plotting_area().dim_in_pixel();
    let (xr, yr) = equal_ranges(bbox, px);
    let mut chart = build((xr.clone(), yr.clone()))?;
    chart
        .configure_mesh()
        .x_desc(view.x_desc)
        .y_desc(view.y_desc)
        .label_style(text(14.0))
        .axis_desc_style(text(16.0))
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(218, 218, 218))
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .draw()?;
    let target = &d.scenario.terminal;
    if view.side {
        // The CG's target altitude.
        chart.draw_series(DashedLineSeries::new(
            vec![(xr.start, target.z_m), (xr.end, target.z_m)],
            6,
            5,
            GREY.stroke_width(1),
        ))?;
    } else {
        // The pad.
        chart.draw_series(std::iter::once(Cross::new(
            (target.x_m, 0.0),
            8,
            GROUND.stroke_width(2),
        )))?;
    }
    for line in lines {
        let seg = [flat(&line[0]), flat(&line[1])];
        for piece in clip_polyline(&seg, &xr, &yr) {
            chart.draw_series(std::iter::once(PathElement::new(
                piece,
                BODY.stroke_width(3),
            )))?;
        }
        if inside(&seg[0], &xr, &yr) {
            chart.draw_series(std::iter::once(Circle::new(seg[0], 3, FLAME.filled())))?;
        }
    }
    let points: Vec<(f64, f64)> = path.iter().map(flat).collect();
    for piece in clip_polyline(&points, &xr, &yr) {
        chart.draw_series(LineSeries::new(piece, SOLUTION.stroke_width(2)))?;
    }
    chart.draw_series(
        d.states
            .iter()
            .map(|s| (s[sx::X + i], s[sx::X + j]))
            .filter(|q| inside(q, &xr, &yr))
            .map(|q| Circle::new(q, 3, SOLUTION.filled())),
    )?;
    Ok(())
}

/// The summary: the answer, where its controls land when flown, and the
/// legend of the views.
fn draw_info<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, d: &SixDofPlot) -> Res<DB> {
    let s = d.solution;
    let mut lines = vec![
        format!("status: {}", s.status.as_str()),
        format!("t_f = {:.3} s, fuel {:.1} kg", s.tf_s, s.fuel_kg),
        format!("final mass {:.1} kg", s.final_mass_kg),
        match s.polish_iterations {
            Some(p) => format!("{} iterations (direct), {p} (polish)", s.iterations),
            None => format!("{} iterations (direct)", s.iterations),
        },
    ];
    if let Some(f) = &s.flown {
        let which = if s.controls_flown.is_some() {
            "polished"
        } else {
            "raw"
        };
        lines.push(format!("{which} controls, flown (DOP853):"));
        lines.push(format!(
            "  land {:.2e} m, {:.2e} m/s from the target",
            f.landing_miss_m, f.landing_miss_mps
        ));
        lines.push(format!(
            "  lowest {:.3} m above the pad before t_f",
            f.lowest_altitude_m
        ));
        lines.push(format!(
            "  nozzle ≤ {:.2}°, its rate ≤ {:.2}°/s",
            f.max_gimbal_deg, f.max_gimbal_rate_degps
        ));
    }
    lines.push(String::new());
    lines.push(format!(
        "line: the CG path, cubic Hermite in (r, V) between the {} nodes (dots)",
        d.states.len()
    ));
    lines.push("black: the vehicle's axis, engine (red) to nose".into());
    lines.push("dashed grey: the CG's target altitude; cross: the pad".into());
    let style = text(16.0);
    for (k, line) in lines.iter().enumerate() {
        area.draw(&Text::new(
            line.clone(),
            (30, 50 + 26 * k as i32),
            style.clone(),
        ))?;
    }
    Ok(())
}
