//! (c) Convergence: per SCvx iteration (virtual control, step, cost, trust
//! radius) or per interior-point iteration (infeasibilities, μ, step length).

use plotters::coord::combinators::IntoLogRange;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

use super::common::{min_max, padded, text, tick, Res, FONT, GREY, REJECTED, SOLUTION};
use super::data::PlotData;

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

pub(super) fn draw_convergence<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    d: &PlotData,
) -> Res<DB> {
    root.fill(&WHITE)?;
    // The panels are those of the history the solve recorded.
    let (title, iterations, panels) = if d.solution.history.scvx.is_empty() {
        direct_panels(d)
    } else {
        scvx_panels(d)
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
    let h = &d.solution.history.scvx;
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
    let h = &d.solution.history.direct;
    let values = |f: fn(&bellyflop::solution::DirectIteration) -> f64| h.iter().map(f).collect();
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
