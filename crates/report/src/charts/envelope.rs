//! Decimation of long traces for drawing: runs of contiguous frames and
//! the min/max envelope of a run per pixel column.
//!
//! A trace of thousands of frames drawn as one polyline point per frame
//! paints a solid block once several frames share a pixel column. Instead
//! every column of the plot keeps the lowest and the highest sample that
//! falls in it; drawing the two as lines with the band between them shows
//! exactly the range of the samples in each column, and nothing a per-frame
//! line would show is lost (docs/report.md, "Traces").

use std::ops::Range;

use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

use crate::model::FrameInfo;

/// The trace charts' drawing area: time in seconds against luma in DN.
pub(super) type Chart<'a, 'b> =
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// A time step longer than this many median frame intervals breaks a run.
pub const GAP_FACTOR: f64 = 1.5;

/// Splits `frames` into runs drawn as connected lines. A run ends where
/// the frame number does not follow on (a dropped or left-out frame) or
/// where the time step exceeds [`GAP_FACTOR`] median steps (a settle gap
/// or a pause), so excluded frames show as gaps, never as ramps.
pub fn runs(frames: &[FrameInfo]) -> Vec<Range<usize>> {
    let mut steps: Vec<f64> = frames
        .windows(2)
        .map(|w| w[1].time_s - w[0].time_s)
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    steps.sort_by(f64::total_cmp);
    let median = steps.get(steps.len() / 2).copied();
    let mut out = Vec::new();
    let mut start = 0;
    for i in 1..=frames.len() {
        let broken = i == frames.len() || {
            let (a, b) = (&frames[i - 1], &frames[i]);
            let dt = b.time_s - a.time_s;
            b.index != a.index + 1 || median.is_some_and(|m| dt > GAP_FACTOR * m)
        };
        if broken && i > start {
            out.push(start..i);
            start = i;
        }
    }
    out
}

/// One pixel column of an envelope.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Column {
    /// Column number, 0 at `t0`.
    pub column: usize,
    /// Lowest sample in the column.
    pub min: f64,
    /// Highest sample in the column.
    pub max: f64,
}

/// The column of time `t` on an axis of `columns` columns over `t0..t1`.
pub fn column_of(t: f64, (t0, t1): (f64, f64), columns: usize) -> usize {
    let u = (t - t0) / (t1 - t0);
    let c = (u * columns as f64).floor();
    if c.is_nan() || c < 0.0 {
        0
    } else {
        (c as usize).min(columns.saturating_sub(1))
    }
}

/// Min and max of the finite samples `(t, v)` in each pixel column over
/// `t0..t1`; columns without a sample are left out. `points` must be in
/// time order (as frames are).
pub fn envelope(points: &[(f64, f64)], span: (f64, f64), columns: usize) -> Vec<Column> {
    let mut out: Vec<Column> = Vec::new();
    if columns == 0 {
        return out;
    }
    for &(t, v) in points.iter().filter(|p| p.1.is_finite()) {
        let c = column_of(t, span, columns);
        match out.last_mut() {
            Some(last) if last.column == c => {
                last.min = last.min.min(v);
                last.max = last.max.max(v);
            }
            _ => out.push(Column {
                column: c,
                min: v,
                max: v,
            }),
        }
    }
    out
}

/// Time at the centre of column `c`.
pub fn column_centre(c: usize, (t0, t1): (f64, f64), columns: usize) -> f64 {
    t0 + (t1 - t0) * (c as f64 + 0.5) / columns.max(1) as f64
}

/// `points` without the interior points of runs of equal value: the
/// same line, drawn from fewer points (a flat trace becomes two points).
pub fn drop_flat(points: &[(f64, f64)]) -> Vec<(f64, f64)> {
    let mut out: Vec<(f64, f64)> = Vec::with_capacity(points.len());
    for (i, &p) in points.iter().enumerate() {
        let flat =
            i > 0 && i + 1 < points.len() && points[i - 1].1 == p.1 && points[i + 1].1 == p.1;
        if !flat {
            out.push(p);
        }
    }
    out
}

/// Draws `points` (time order) as a line; when there are more points than
/// `columns` pixel columns over `span`, as the min and max line per column
/// with the band between them filled (`band`), else point by point.
pub(super) fn draw_decimated(
    chart: &mut Chart<'_, '_>,
    points: &[(f64, f64)],
    span: (f64, f64),
    columns: usize,
    colour: RGBColor,
    band: Option<RGBAColor>,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<std::io::Error>| e.to_string();
    let line = |chart: &mut Chart<'_, '_>, points: Vec<(f64, f64)>| {
        chart
            .draw_series(LineSeries::new(points, colour.stroke_width(1)))
            .map(|_| ())
            .map_err(e)
    };
    if points.len() <= columns {
        return line(chart, drop_flat(points));
    }
    let env = envelope(points, span, columns);
    let x = |c: usize| column_centre(c, span, columns);
    let max: Vec<(f64, f64)> = env.iter().map(|c| (x(c.column), c.max)).collect();
    if env.iter().all(|c| c.min == c.max) {
        // One sample per column or a flat trace: a single line.
        return line(chart, drop_flat(&max));
    }
    let min: Vec<(f64, f64)> = env.iter().map(|c| (x(c.column), c.min)).collect();
    let (max, min) = (drop_flat(&max), drop_flat(&min));
    if let Some(fill) = band {
        let outline: Vec<(f64, f64)> = max.iter().chain(min.iter().rev()).copied().collect();
        chart
            .draw_series(std::iter::once(Polygon::new(outline, fill.filled())))
            .map_err(e)?;
    }
    line(chart, min)?;
    line(chart, max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use ledflicker_core::metrics::flicker::Segment;

    fn frame(index: u64, time_s: f64) -> FrameInfo {
        FrameInfo {
            index,
            time_s,
            segment: Segment::Pwm,
        }
    }

    #[test]
    fn envelope_matches_a_brute_force_min_max() {
        // A beat-like signal, 1,920 frames over 64 s, into 613 columns.
        let points: Vec<(f64, f64)> = (0..1920)
            .map(|i| {
                let t = i as f64 / 30.0;
                (
                    t,
                    40.0 + 5.0 * (2.0 * std::f64::consts::PI * 0.37 * t).sin() + (i % 7) as f64,
                )
            })
            .collect();
        let span = (0.0, 64.0);
        let columns = 613;
        let env = envelope(&points, span, columns);
        for c in 0..columns {
            // Brute force: every sample whose time maps into column c.
            let t_lo = span.0 + (span.1 - span.0) * c as f64 / columns as f64;
            let t_hi = span.0 + (span.1 - span.0) * (c + 1) as f64 / columns as f64;
            let inside: Vec<f64> = points
                .iter()
                .filter(|p| p.0 >= t_lo && p.0 < t_hi)
                .map(|p| p.1)
                .collect();
            let got = env.iter().find(|e| e.column == c);
            if inside.is_empty() {
                assert!(got.is_none(), "column {c} has no sample");
                continue;
            }
            let got = got.unwrap();
            let lo = inside.iter().copied().fold(f64::INFINITY, f64::min);
            let hi = inside.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            assert_eq!((got.min, got.max), (lo, hi), "column {c}");
        }
        assert!(env.len() <= columns);
        assert_eq!(
            env.iter().map(|e| e.column).collect::<Vec<_>>(),
            {
                let mut v: Vec<usize> = env.iter().map(|e| e.column).collect();
                v.dedup();
                v
            },
            "one entry per column"
        );
    }

    #[test]
    fn envelope_skips_non_finite_samples_and_clamps_the_ends() {
        let env = envelope(&[(-1.0, 1.0), (0.5, f64::NAN), (2.0, 3.0)], (0.0, 1.0), 4);
        assert_eq!(
            env,
            vec![
                Column {
                    column: 0,
                    min: 1.0,
                    max: 1.0
                },
                Column {
                    column: 3,
                    min: 3.0,
                    max: 3.0
                }
            ]
        );
        assert!(envelope(&[(0.0, 1.0)], (0.0, 1.0), 0).is_empty());
    }

    #[test]
    fn runs_break_at_dropped_frames_and_time_gaps() {
        let dt = 1.0 / 30.0;
        let mut frames: Vec<FrameInfo> = (0..10).map(|i| frame(i, i as f64 * dt)).collect();
        // Frame 10 dropped; frames 11..15 follow.
        frames.extend((11..15).map(|i| frame(i, i as f64 * dt)));
        // A settle gap of 0.5 s, numbering continues (a capture that left
        // the settle frames out of the segment but numbers them on).
        frames.extend((15..20).map(|i| frame(i, 0.5 + i as f64 * dt)));
        assert_eq!(runs(&frames), vec![0..10, 10..14, 14..19]);
        assert_eq!(runs(&frames[..3]), vec![0..3]);
        assert!(runs(&[]).is_empty());
    }

    #[test]
    fn drop_flat_keeps_every_corner() {
        let pts = [
            (0.0, 1.0),
            (1.0, 1.0),
            (2.0, 1.0),
            (3.0, 2.0),
            (4.0, 2.0),
            (5.0, 1.0),
        ];
        assert_eq!(
            drop_flat(&pts),
            vec![(0.0, 1.0), (2.0, 1.0), (3.0, 2.0), (4.0, 2.0), (5.0, 1.0)]
        );
        assert_eq!(drop_flat(&pts[..1]), vec![(0.0, 1.0)]);
    }
}
