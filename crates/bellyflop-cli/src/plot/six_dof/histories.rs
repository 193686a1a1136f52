//! The 6-DoF time histories: altitude, horizontal position, speed, tilt,
//! body rates, mass, thrust, gimbal angles and gimbal rates, at the nodes,
//! with the bounds.

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::SixDofPlot;
use crate::plot::common::{
    history_chart, min_max, near_bounds, text, Res, FONT, GREY, OVERLAY, SOLUTION, SWITCH,
};
use bellyflop::problem::six_dof::{su, sx};

/// The colours of a panel's curves, in order.
const COLOURS: [RGBColor; 3] = [SOLUTION, OVERLAY, SWITCH];

/// One curve: its name in the legend, times and values.
struct Curve {
    name: &'static str,
    t_s: Vec<f64>,
    y: Vec<f64>,
}

/// One panel: its caption with the unit, its curves, and horizontal bounds
/// with their names.
struct Panel {
    label: &'static str,
    curves: Vec<Curve>,
    bounds: Vec<(f64, &'static str)>,
}

/// The panels, in reading order.
fn panels(d: &SixDofPlot) -> Vec<Panel> {
    let v = &d.scenario.vehicle;
    let deg = 180.0 / std::f64::consts::PI;
    let t = d.t_s.clone();
    let tu = d.control_times().to_vec();
    let curve = |name, t_s: &Vec<f64>, y| Curve {
        name,
        t_s: t_s.clone(),
        y,
    };
    vec![
        Panel {
            label: "z, altitude [m]",
            curves: vec![curve("z", &t, d.state(sx::Z, 1.0))],
            bounds: vec![],
        },
        Panel {
            label: "x, y, position [m]",
            curves: vec![
                curve("x", &t, d.state(sx::X, 1.0)),
                curve("y", &t, d.state(sx::Y, 1.0)),
            ],
            bounds: vec![],
        },
        Panel {
            label: "‖V‖, speed [m/s]",
            curves: vec![curve("‖V‖", &t, d.speed())],
            bounds: vec![],
        },
        Panel {
            label: "tilt of the axis from vertical [deg]",
            curves: vec![curve("tilt", &t, d.tilt_deg())],
            bounds: vec![],
        },
        Panel {
            label: "ω, body rates [deg/s]",
            curves: vec![
                curve("ωx", &t, d.state(sx::W, deg)),
                curve("ωy", &t, d.state(sx::W + 1, deg)),
                curve("ωz (roll)", &t, d.state(sx::W + 2, deg)),
            ],
            bounds: vec![],
        },
        Panel {
            label: "m, mass [kg]",
            curves: vec![curve("m", &t, d.state(sx::M, 1.0))],
            bounds: vec![(v.dry_mass_kg, "m_dry")],
        },
        Panel {
            label: "T, thrust [kN]",
            curves: vec![curve("T", &tu, d.thrust_kn())],
            bounds: vec![
                (v.min_thrust_n * 1e-3, "T_min"),
                (v.max_thrust_n * 1e-3, "T_max"),
            ],
        },
        Panel {
            label: "δ1, δ2, gimbal angles [deg]",
            curves: vec![
                curve("δ1", &t, d.state(sx::DELTA, deg)),
                curve("δ2", &t, d.state(sx::DELTA + 1, deg)),
            ],
            bounds: vec![(-v.max_gimbal_deg, "−δ_max"), (v.max_gimbal_deg, "δ_max")],
        },
        Panel {
            label: "χ1, χ2, gimbal rates [deg/s]",
            curves: vec![
                curve("χ1", &tu, d.control(su::CHI, deg)),
                curve("χ2", &tu, d.control(su::CHI + 1, deg)),
            ],
            bounds: vec![
                (-v.max_gimbal_rate_degps, "−χ_max"),
                (v.max_gimbal_rate_degps, "χ_max"),
            ],
        },
    ]
}

pub(super) fn draw_histories<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &SixDofPlot,
) -> Res<DB> {
    root.fill(&WHITE)?;
    let root = root.titled(
        &format!("Time histories, 6-DoF — {}", d.title()),
        (FONT, 22).into_font().style(FontStyle::Bold),
    )?;
    let areas = root.split_evenly((3, 3));
    for (area, p) in areas.iter().zip(&panels(d)) {
        draw_panel(area, d.solution.tf_s, p)?;
    }
    Ok(())
}

/// One panel: its curves joined at the nodes (dots), the bounds near the
/// data (dashed, named), and a legend when it has several curves.
fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, tf: f64, p: &Panel) -> Res<DB> {
    let (mut lo, mut hi) = min_max(p.curves.iter().flat_map(|c| c.y.iter().copied()));
    if lo > hi {
        (lo, hi) = (0.0, 1.0);
    }
    let shown = near_bounds(&mut lo, &mut hi, &p.bounds);
    let t_end = if tf.is_finite() && tf > 0.0 {
        tf * 1.02
    } else {
        1.0
    };
    let mut chart = history_chart(area, p.label, 0.0..t_end, (lo, hi))?;
    for (b, name) in &shown {
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
    for (c, colour) in p.curves.iter().zip(COLOURS) {
        let points: Vec<(f64, f64)> = c.t_s.iter().copied().zip(c.y.iter().copied()).collect();
        chart
            .draw_series(LineSeries::new(points.clone(), colour.stroke_width(2)))?
            .label(c.name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 22, y)], colour.stroke_width(2))
            });
        chart.draw_series(
            points
                .into_iter()
                .map(|q| Circle::new(q, 3, colour.filled())),
        )?;
    }
    if p.curves.len() > 1 {
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
