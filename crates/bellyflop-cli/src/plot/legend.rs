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

/// The legend and a summary of the trajectory, in the right-hand column.
pub(super) fn draw_path_info<DB: DrawingBackend>(
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
