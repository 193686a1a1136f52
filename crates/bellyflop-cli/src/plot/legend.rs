//! The right-hand column of the path plot: the legend and a summary of the
//! trajectory.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;

use super::common::{
    fixed, text, tick, Res, BODY, FLAME, FONT, GREY, GROUND, OVERLAY, SOLUTION, SWITCH,
};
use super::data::PlotData;

/// Rows of the column, in pixels.
const LINE_H: i32 = 24;
/// Where a legend entry's glyph and its text start, in pixels.
const GLYPH_X: i32 = 4;
const TEXT_X: i32 = 44;

/// The right-hand column, written top to bottom: `y` is the next row.
struct Column<'a, DB: DrawingBackend> {
    area: &'a DrawingArea<DB, Shift>,
    y: i32,
}

impl<DB: DrawingBackend> Column<'_, DB> {
    /// A bold heading at the left edge, with some room below it.
    fn heading(&mut self, title: &str) -> Res<DB> {
        let head = (FONT, 17.0)
            .into_font()
            .style(FontStyle::Bold)
            .color(&BLACK);
        self.area.draw(&Text::new(title, (0, self.y), head))?;
        self.y += LINE_H + 6;
        Ok(())
    }

    /// A legend entry: its glyph (drawn at the row's height), then its text.
    fn entry(&mut self, glyph: &dyn Fn(i32) -> Res<DB>, label: String) -> Res<DB> {
        glyph(self.y)?;
        self.text(TEXT_X, label)
    }

    /// A line of text starting at `x`.
    fn text(&mut self, x: i32, label: String) -> Res<DB> {
        self.area.draw(&Text::new(
            label,
            (x, self.y),
            text(15.0).pos(Pos::new(HPos::Left, VPos::Center)),
        ))?;
        self.y += LINE_H;
        Ok(())
    }
}

/// The legend and a summary of the trajectory, in the right-hand column.
pub(super) fn draw_path_info<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    d: &PlotData,
    flame_at_max_m: f64,
    ground_m: f64,
) -> Res<DB> {
    let area = &area.margin(40, 10, 10, 10);
    let mut column = Column { area, y: 10 };
    column.heading("Legend")?;
    draw_legend(&mut column, d, flame_at_max_m, ground_m)?;
    column.y += LINE_H;
    column.heading("Summary")?;
    for l in summary_lines(d) {
        column.text(0, l)?;
    }
    Ok(())
}

/// The legend's entries: the paths, the nodes, the vehicle, its thrust, the
/// switches, the target and the ground.
fn draw_legend<DB: DrawingBackend>(
    column: &mut Column<DB>,
    d: &PlotData,
    flame_at_max_m: f64,
    ground_m: f64,
) -> Res<DB> {
    let v = &d.scenario.vehicle;
    let area = column.area;
    let line = |color: RGBColor, width: u32| {
        move |y: i32| -> Res<DB> {
            area.draw(&PathElement::new(
                vec![(GLYPH_X, y), (GLYPH_X + 30, y)],
                color.stroke_width(width),
            ))
        }
    };
    // Two short strokes: the look of a dashed line.
    let dashed = |style: ShapeStyle, gap: (i32, i32)| {
        move |y: i32| -> Res<DB> {
            area.draw(&PathElement::new(
                vec![(GLYPH_X, y), (GLYPH_X + gap.0, y)],
                style,
            ))?;
            area.draw(&PathElement::new(
                vec![(GLYPH_X + gap.1, y), (GLYPH_X + 30, y)],
                style,
            ))
        }
    };
    column.entry(&line(SOLUTION, 2), "path of the centre of mass (CG)".into())?;
    column.entry(
        &|y| area.draw(&Circle::new((GLYPH_X + 15, y), 3, SOLUTION.filled())),
        format!("LGR nodes ({})", d.nodes.len()),
    )?;
    if d.overlay.is_some() {
        column.entry(
            &dashed(OVERLAY.stroke_width(2), (10, 18)),
            "re-integrated trajectory (dashed), × its end".into(),
        )?;
    }
    column.entry(
        &|y| {
            area.draw(&Rectangle::new(
                [(GLYPH_X, y - 5), (GLYPH_X + 24, y + 5)],
                RGBColor(200, 212, 230).filled(),
            ))?;
            area.draw(&Rectangle::new(
                [(GLYPH_X, y - 5), (GLYPH_X + 24, y + 5)],
                BODY.stroke_width(1),
            ))?;
            area.draw(&Polygon::new(
                vec![
                    (GLYPH_X + 24, y - 5),
                    (GLYPH_X + 32, y),
                    (GLYPH_X + 24, y + 5),
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
    column.text(TEXT_X, "above the engine, drawn at the CG point".into())?;
    column.entry(
        &line(FLAME, 4),
        format!("thrust along the nozzle, length ∝ T ({flame_at_max_m:.0} m"),
    )?;
    column.text(
        TEXT_X,
        format!(
            "at T_max = {:.0} kN; T_min = {:.0} kN)",
            v.max_thrust_n / 1e3,
            v.min_thrust_n / 1e3
        ),
    )?;
    column.entry(
        &|y| area.draw(&TriangleMarker::new((GLYPH_X + 15, y), 9, SWITCH.filled())),
        "thrust switch".into(),
    )?;
    column.entry(
        &dashed(GREY.stroke_width(1), (12, 18)),
        format!(
            "target altitude of the CG, z_f = {} m",
            tick(d.scenario.terminal.z_m)
        ),
    )?;
    column.entry(
        &line(GROUND, 3),
        format!("ground: engine at touchdown, z = {} m", tick(ground_m)),
    )
}

/// The summary's lines: status, t_f, mass, the flip, the switches, the
/// extremes of the controls, the touchdown and, with an overlay, its miss.
fn summary_lines(d: &PlotData) -> Vec<String> {
    let v = &d.scenario.vehicle;
    let dense = d.dense;
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
            "status {}, {} {} iterations",
            d.solution.status.as_str(),
            d.solution.iterations,
            d.method_names().iterations
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
    lines
}
