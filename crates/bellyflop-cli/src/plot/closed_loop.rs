//! Plots of closed-loop runs, each as SVG and PNG (plotters, embedded font):
//!
//! - `timeline` (`sim --out`): solve time and SCvx iterations of every re-plan;
//! - `touchdown` (`montecarlo --out`): touchdown scatter, position error
//!   against vertical speed and pitch error against horizontal speed, with
//!   the requirement box;
//! - `replan_times` (`montecarlo --out`): histogram of re-plan solve times.

use std::path::{Path, PathBuf};

use bellyflop::guidance::{Flight, ReplanOutcome};
use bellyflop::output::campaign::RunRow;
use plotters::prelude::*;

use super::common::{fonts, Res, FONT};
use crate::error::OutputError;
use crate::files::commit;

const BLUE: RGBColor = RGBColor(31, 90, 180);
const RED: RGBColor = RGBColor(200, 30, 30);
const GREEN: RGBColor = RGBColor(0, 140, 70);
const GREY: RGBColor = RGBColor(130, 130, 130);

/// Draw `draw` as DIR/STEM.svg and DIR/STEM.png.
fn both(
    dir: &Path,
    stem: &str,
    size: (u32, u32),
    draw: &dyn for<'a> Fn(
        &DrawingArea<SVGBackend<'a>, plotters::coord::Shift>,
    ) -> Res<SVGBackend<'a>>,
    draw_png: &dyn for<'a> Fn(
        &DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>,
    ) -> Res<BitMapBackend<'a>>,
) -> Result<Vec<PathBuf>, OutputError> {
    fonts();
    let svg = dir.join(format!("{stem}.svg"));
    commit(&svg, |tmp| {
        let root = SVGBackend::new(tmp, size).into_drawing_area();
        draw(&root)
            .and_then(|()| root.present())
            .map_err(|e| OutputError::plot(&svg, e))
    })?;
    let png = dir.join(format!("{stem}.png"));
    commit(&png, |tmp| {
        let root = BitMapBackend::new(tmp, size).into_drawing_area();
        draw_png(&root)
            .and_then(|()| root.present())
            .map_err(|e| OutputError::plot(&png, e))
    })?;
    Ok(vec![svg, png])
}

fn span(values: impl Iterator<Item = f64>, floor: f64) -> f64 {
    values
        .filter(|v| v.is_finite())
        .fold(floor, |m, v| m.max(v.abs()))
        * 1.1
}

/// The re-plan timeline of one flight.
pub fn timeline(dir: &Path, f: &Flight) -> Result<Vec<PathBuf>, OutputError> {
    fn draw<DB: DrawingBackend>(
        root: &DrawingArea<DB, plotters::coord::Shift>,
        f: &Flight,
    ) -> Res<DB> {
        root.fill(&WHITE)?;
        let (top, bottom) = root.split_vertically(root.dim_in_pixel().1 / 2);
        let tmax = f.replans.iter().map(|r| r.time_s).fold(1.0, f64::max) + 0.5;
        let ms = span(f.replans.iter().map(|r| r.solve_ms), 1.0);
        let its = span(f.replans.iter().map(|r| r.iterations as f64), 1.0);
        let colour = |o: ReplanOutcome| match o {
            ReplanOutcome::Accepted => BLUE,
            ReplanOutcome::Usable => GREEN,
            ReplanOutcome::Failed => RED,
            ReplanOutcome::Missed => GREY,
        };
        for (area, label, max, value) in [
            (&top, "solve time [ms]", ms, 0usize),
            (&bottom, "SCvx iterations", its, 1usize),
        ] {
            let mut c = ChartBuilder::on(area)
                .caption(
                    if value == 0 {
                        "Re-plans: solve time (blue solved, green usable at the budget, red failed, grey missed)"
                    } else {
                        "Re-plans: SCvx iterations"
                    },
                    (FONT, 20),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(0.0..tmax, 0.0..max)?;
            c.configure_mesh()
                .x_desc("time of the measurement [s]")
                .y_desc(label)
                .label_style((FONT, 15))
                .draw()?;
            c.draw_series(f.replans.iter().map(|r| {
                let y = if value == 0 {
                    r.solve_ms
                } else {
                    r.iterations as f64
                };
                Rectangle::new(
                    [(r.time_s - 0.15, 0.0), (r.time_s + 0.15, y)],
                    colour(r.outcome).filled(),
                )
            }))?;
        }
        Ok(())
    }
    both(
        dir,
        "timeline",
        (1200, 800),
        &|root| draw(root, f),
        &|root| draw(root, f),
    )
}

/// Touchdown scatter and re-plan time histogram of a campaign.
pub fn campaign(dir: &Path, rows: &[RunRow], name: &str) -> Result<Vec<PathBuf>, OutputError> {
    fn scatter<DB: DrawingBackend>(
        root: &DrawingArea<DB, plotters::coord::Shift>,
        rows: &[RunRow],
        name: &str,
    ) -> Res<DB> {
        root.fill(&WHITE)?;
        let (left, right) = root.split_horizontally(root.dim_in_pixel().0 / 2);
        let landed: Vec<&RunRow> = rows.iter().filter(|r| r.touchdown()).collect();
        // The landing spec the runs were judged by (the same for all).
        let spec = rows.first().map(|r| r.limits).unwrap_or_default();
        // (area, x label, y label, x requirement, y requirement, the point)
        type Panel<'a, A> = (&'a A, &'a str, &'a str, f64, f64, fn(&RunRow) -> (f64, f64));
        let panels: [Panel<DrawingArea<DB, _>>; 2] = [
            (
                &left,
                "position error x - x_f [m]",
                "vertical speed [m/s]",
                spec.landed_position_m,
                spec.landed_speed_mps,
                |r| (r.x_error_m, r.vertical_velocity_mps.abs()),
            ),
            (
                &right,
                "pitch error [deg]",
                "horizontal speed [m/s]",
                spec.landed_pitch_deg,
                spec.landed_speed_mps,
                |r| (r.pitch_error_deg, r.horizontal_velocity_mps.abs()),
            ),
        ];
        for (area, xl, yl, xs, ys, get) in panels {
            let xr = span(landed.iter().map(|r| get(r).0), 1.5 * xs);
            let yr = span(landed.iter().map(|r| get(r).1), 1.5 * ys);
            let mut c = ChartBuilder::on(area)
                .caption(
                    format!("{name}: {} touchdowns of {} runs", landed.len(), rows.len()),
                    (FONT, 20),
                )
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(60)
                .build_cartesian_2d(-xr..xr, 0.0..yr)?;
            c.configure_mesh()
                .x_desc(xl)
                .y_desc(yl)
                .label_style((FONT, 15))
                .draw()?;
            c.draw_series(std::iter::once(Rectangle::new(
                [(-xs, 0.0), (xs, ys)],
                GREEN.stroke_width(2),
            )))?;
            c.draw_series(landed.iter().map(|r| {
                let (x, y) = get(r);
                let col = if r.in_spec() { BLUE } else { RED };
                Circle::new((x, y), 3, col.filled())
            }))?;
        }
        Ok(())
    }
    fn histogram<DB: DrawingBackend>(
        root: &DrawingArea<DB, plotters::coord::Shift>,
        rows: &[RunRow],
    ) -> Res<DB> {
        root.fill(&WHITE)?;
        let ms: Vec<f64> = rows
            .iter()
            .flat_map(|r| r.replan_ms.iter().copied())
            .collect();
        let max = ms.iter().copied().fold(1.0, f64::max);
        let bins = 50usize;
        let width = max / bins as f64;
        let mut counts = vec![0u32; bins];
        for v in &ms {
            counts[((v / width) as usize).min(bins - 1)] += 1;
        }
        let top = counts.iter().copied().max().unwrap_or(1).max(1) as f64 * 1.1;
        let mut c = ChartBuilder::on(root)
            .caption(
                format!("Re-plan solve time, {} re-plans", ms.len()),
                (FONT, 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..max * 1.02, 0.0..top)?;
        c.configure_mesh()
            .x_desc("solve time [ms]")
            .y_desc("re-plans")
            .label_style((FONT, 15))
            .draw()?;
        c.draw_series(counts.iter().enumerate().map(|(k, &n)| {
            let x0 = k as f64 * width;
            Rectangle::new([(x0, 0.0), (x0 + width, n as f64)], BLUE.filled())
        }))?;
        Ok(())
    }
    let mut files = both(
        dir,
        "touchdown",
        (1400, 650),
        &|root| scatter(root, rows, name),
        &|root| scatter(root, rows, name),
    )?;
    files.extend(both(
        dir,
        "replan_times",
        (1000, 600),
        &|root| histogram(root, rows),
        &|root| histogram(root, rows),
    )?);
    Ok(files)
}
