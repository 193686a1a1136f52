//! (b) The time histories: x, z, Vx, Vz, θ, w, m, T, δ against time, with
//! the nodes, bounds, switches and mesh breaks.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::FontStyle;

use super::common::{
    history_chart, min_max, near_bounds, text, Chart, Res, BREAK, FONT, GREY, OVERLAY, SOLUTION,
    SWITCH,
};
use super::data::PlotData;
use crate::sample::Dense;

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

pub(super) fn draw_histories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &PlotData,
) -> Res<DB> {
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
    let shown = near_bounds(&mut lo, &mut hi, &h.bounds);
    let t_range = 0.0..tf * 1.02;
    let mut chart = history_chart(area, h.label, t_range.clone(), (lo, hi))?;

    draw_marks(&mut chart, d, &shown, t_range.end)?;
    draw_curves(&mut chart, d, &y, &y_nodes, y_over.as_deref())?;
    if let Some(note) = h.note {
        draw_note(&mut chart, note)?;
    }
    if legend {
        draw_legend(&mut chart, d)?;
    }
    Ok(())
}

/// The vertical lines of the mesh breaks and thrust switches, and the bounds
/// shown (up to `t_end`) with their names.
fn draw_marks<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    d: &PlotData,
    shown: &[(f64, &str)],
    t_end: f64,
) -> Res<DB> {
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
    for (b, name) in shown {
        chart.draw_series(DashedLineSeries::new(
            vec![(0.0, *b), (t_end, *b)],
            6,
            4,
            GREY.stroke_width(1),
        ))?;
        chart.draw_series(std::iter::once(
            EmptyElement::at((t_end, *b))
                + Text::new(name.to_string(), (-48, -16), text(12.0).color(&GREY)),
        ))?;
    }
    Ok(())
}

/// The interpolant, the nodes and the overlay (dashed), each with its
/// legend entry.
fn draw_curves<'a, DB: DrawingBackend + 'a>(
    chart: &mut Chart<'a, DB>,
    d: &PlotData,
    y: &[f64],
    y_nodes: &[f64],
    y_over: Option<&[f64]>,
) -> Res<DB> {
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
                .zip(y_nodes)
                .map(|(&t, &v)| Circle::new((t, v), 3, SOLUTION.filled())),
        )?
        .label("LGR nodes")
        .legend(|(x, y)| Circle::new((x + 11, y), 3, SOLUTION.filled()));
    if let (Some(o), Some(yo)) = (d.overlay, y_over) {
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
    Ok(())
}

/// A remark in the upper left of the panel.
fn draw_note<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>, note: &str) -> Res<DB> {
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
    Ok(())
}

/// The legend of the first panel: the curves, and the breaks and switches
/// when there are any.
fn draw_legend<'a, DB: DrawingBackend + 'a>(chart: &mut Chart<'a, DB>, d: &PlotData) -> Res<DB> {
    if !d.breaks_s.is_empty() {
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
            .label("mesh interval break")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], BREAK.stroke_width(1)));
    }
    if !d.switches.is_empty() {
        chart
            .draw_series(std::iter::empty::<Circle<(f64, f64), i32>>())?
            .label("thrust switch")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], SWITCH.stroke_width(1)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .label_font(text(12.0))
        .background_style(WHITE.mix(0.9))
        .border_style(GREY)
        .draw()?;
    Ok(())
}
