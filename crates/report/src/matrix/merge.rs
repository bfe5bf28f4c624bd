//! The cells of a matrix denser than its pixels, merged: a sweep of
//! thousands of frequencies draws one cell per pixel column and row.

use std::collections::BTreeMap;
use std::ops::Range;

use super::{Grid, Shown};
use crate::model::Verdict;
use crate::model::plane::PlaneCell;

/// The cells a matrix draws, each with the columns it spans: every case's
/// own cell while a column is at least a pixel wide; in a denser sweep the
/// cells of a row that fall in one pixel column are merged into one, which
/// shows the worst of them (the lowest FDI, the highest Percent Flicker or
/// visibility; an undefined value only when all are) and fails when any
/// fails (else passes when any passes), so that no failing case is hidden
/// and the SVG stays the size of the picture.
pub(super) fn merged_cells(
    cells: &[PlaneCell],
    grid: &Grid,
    kind: Shown,
) -> Vec<(Range<usize>, PlaneCell)> {
    if grid.cell_w >= 1.0 {
        return cells.iter().map(|c| (c.column..c.column + 1, *c)).collect();
    }
    // How bad a value is: higher is worse; an unbounded FDI is the best.
    let badness = |c: &PlaneCell| match (c.value, c.unbounded, kind) {
        (_, true, _) => f64::NEG_INFINITY,
        (None, false, _) => f64::NAN,
        (Some(v), false, Shown::Fdi) => -v,
        (Some(v), false, _) => v,
    };
    let verdict = |a: Verdict, b: Verdict| match (a, b) {
        (Verdict::Fail, _) | (_, Verdict::Fail) => Verdict::Fail,
        (Verdict::Pass, _) | (_, Verdict::Pass) => Verdict::Pass,
        _ => Verdict::Info,
    };
    let mut merged: BTreeMap<(usize, usize), (Range<usize>, PlaneCell)> = BTreeMap::new();
    for c in cells {
        let pixel = (c.column as f64 * grid.cell_w).floor() as usize;
        let (span, worst) = merged
            .entry((pixel, c.row))
            .or_insert((c.column..c.column + 1, *c));
        span.start = span.start.min(c.column);
        span.end = span.end.max(c.column + 1);
        let v = verdict(worst.verdict, c.verdict);
        let (bw, bc) = (badness(worst), badness(c));
        if bw.is_nan() || (!bc.is_nan() && bc > bw) {
            *worst = *c;
        }
        worst.verdict = v;
    }
    merged.into_values().collect()
}

#[cfg(test)]
mod tests {
    use super::super::{LEFT, RIGHT};
    use super::*;

    #[test]
    fn cells_denser_than_pixels_merge_into_the_worst_case_of_each_pixel_column() {
        let (cols, rows) = (2_500, 3);
        let grid = Grid::new(cols, rows);
        assert!(grid.cell_w < 1.0);
        // Values that rise and fall over the columns, some undefined, one
        // unbounded FDI, verdicts mixed.
        let cell = |column: usize, row: usize| {
            let k = column * rows + row;
            PlaneCell {
                column,
                row,
                frequency_hz: column as f64,
                duty: row as f64,
                verdict: match k % 7 {
                    0 => Verdict::Fail,
                    1 | 2 => Verdict::Info,
                    _ => Verdict::Pass,
                },
                value: (!k.is_multiple_of(11)).then(|| ((k * 37) % 101) as f64 / 10.0),
                unbounded: k == 4,
            }
        };
        let cells: Vec<PlaneCell> = (0..cols)
            .flat_map(|c| (0..rows).map(move |r| (c, r)))
            .map(|(c, r)| cell(c, r))
            .collect();
        for kind in [Shown::Fdi, Shown::PercentFlicker] {
            let merged = merged_cells(&cells, &grid, kind);
            let pixels = (f64::from(RIGHT - LEFT)).ceil() as usize;
            assert!(merged.len() <= pixels * rows, "{}", merged.len());
            // Every column of every row is in exactly one merged cell.
            let mut covered = vec![0; cols * rows];
            for (span, m) in &merged {
                for c in span.clone() {
                    covered[c * rows + m.row] += 1;
                }
                // Brute force over the merged cases.
                let group: Vec<PlaneCell> = span.clone().map(|c| cell(c, m.row)).collect();
                let fails = group.iter().any(|g| g.verdict == Verdict::Fail);
                let passes = group.iter().any(|g| g.verdict == Verdict::Pass);
                let want = match (fails, passes) {
                    (true, _) => Verdict::Fail,
                    (false, true) => Verdict::Pass,
                    _ => Verdict::Info,
                };
                assert_eq!(m.verdict, want);
                let defined = group
                    .iter()
                    .filter(|g| !g.unbounded)
                    .filter_map(|g| g.value);
                let worst = match kind {
                    Shown::Fdi => defined.fold(f64::INFINITY, f64::min),
                    _ => defined.fold(f64::NEG_INFINITY, f64::max),
                };
                if worst.is_finite() {
                    assert_eq!((m.value, m.unbounded), (Some(worst), false), "{span:?}");
                }
            }
            assert!(covered.iter().all(|&n| n == 1));
        }
        // A grid with a pixel or more per column draws every case's cell.
        let few: Vec<PlaneCell> = cells.iter().filter(|c| c.column < 50).copied().collect();
        let merged = merged_cells(&few, &Grid::new(50, rows), Shown::Fdi);
        assert_eq!(merged.len(), few.len());
        assert!(
            merged
                .iter()
                .zip(&few)
                .all(|((s, m), c)| *m == *c && s.len() == 1)
        );
    }
}
