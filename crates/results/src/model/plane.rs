//! The cases of one light level on the PWM frequency x duty plane, and
//! where Deegan 2018 Eq. (1) says the LED can appear OFF there.
//!
//! Part of the results model: computed from results.json's fields alone
//! (`cases` and `dut.camera`), so a model read back from a report directory
//! gives the same plane. The report's matrix draws it
//! (`ledflicker_report::matrix`) and computes nothing of its own.

use super::{CaseInfo, Results, RoiKind, Verdict};

/// One light level's cases on the frequency x duty plane.
#[derive(Debug, Clone)]
pub struct LevelPlane {
    /// Illuminance, lux (> 0).
    pub light_lux: f64,
    /// PWM frequencies of the cases, Hz, ascending and distinct: the
    /// columns.
    pub frequencies_hz: Vec<f64>,
    /// Duty cycles of the cases, percent, ascending and distinct: the rows,
    /// row 0 the lowest.
    pub duties_percent: Vec<f64>,
    /// Every case at this light level, in plan order, with its cell.
    pub cells: Vec<PlaneCell>,
    /// Deegan 2018 Eq. (1) for the simulated camera's exposure; `None`
    /// without a camera or with a zero exposure.
    pub eq1: Option<Eq1>,
}

/// A case's cell of a [`LevelPlane`]: what its matrix shows of it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneCell {
    /// Column: index into `frequencies_hz`.
    pub column: usize,
    /// Row: index into `duties_percent`.
    pub row: usize,
    /// The case's PWM frequency, Hz.
    pub frequency_hz: f64,
    /// The case's duty cycle, 0..1.
    pub duty: f64,
    /// The case's verdict on the plane's metric ([`metric_verdict`]).
    pub verdict: Verdict,
    /// The plane's metric ([`shown_value`]).
    pub value: Option<f64>,
    /// Whether the value is +infinity ([`shown_value`]).
    pub unbounded: bool,
}

/// The value a matrix shows for a case: `metric` of its first LED ROI
/// (else its first ROI), and whether it is +infinity (an FDI whose
/// contrast is unbounded).
pub fn shown_value(case: &CaseInfo, metric: &str) -> (Option<f64>, bool) {
    let Some(roi) = case
        .rois
        .iter()
        .find(|r| r.kind == RoiKind::Led)
        .or(case.rois.first())
    else {
        return (None, false);
    };
    let unbounded = roi.contrast_unbounded && metric.starts_with("fdi");
    (roi.metrics.get(metric).copied().flatten(), unbounded)
}

/// The verdict a matrix of `metric` marks in a case: the case's verdict
/// on that metric alone (fail when one of its checks fails, pass when all
/// of them pass), so that a case failing on another metric is not marked
/// failed in a cell whose value meets its limit. A case not judged stays
/// info; a case with no check of `metric` shows its own verdict.
pub fn metric_verdict(case: &CaseInfo, metric: &str) -> Verdict {
    let family = |m: &str| m.trim_end_matches("_worst_phase").to_string();
    let mine: Vec<bool> = case
        .checks
        .iter()
        .filter(|c| family(&c.metric) == family(metric))
        .map(|c| c.pass)
        .collect();
    match case.verdict {
        Verdict::Info => Verdict::Info,
        _ if mine.is_empty() => case.verdict,
        _ if mine.iter().all(|&p| p) => Verdict::Pass,
        _ => Verdict::Fail,
    }
}

/// Deegan 2018 Eq. (1) on a plane: an exposure `T_exp` can fall entirely
/// in the OFF part of a PWM period, so the LED can appear OFF, when
/// `T_exp < (1 - D) / f`, that is `D < 1 - f T_exp`.
#[derive(Debug, Clone, PartialEq)]
pub struct Eq1 {
    /// The camera's exposure `T_exp`, milliseconds (> 0).
    pub exposure_ms: f64,
    /// Per column, the number of rows from the lowest duty where the LED
    /// can appear OFF ([`eq1_rows`]).
    pub off_rows: Vec<usize>,
}

impl Eq1 {
    /// Whether the LED can appear OFF in some cell.
    pub fn any_off(&self) -> bool {
        self.off_rows.iter().any(|&b| b > 0)
    }
}

/// Per frequency column, the number of duty rows (from the lowest) where
/// Deegan 2018 Eq. (1) says the LED can appear OFF: `D < 1 - f T_exp`
/// (duties in percent, exposure in seconds; a duty within 1e-9 % of the
/// limit is on it, not below).
pub fn eq1_rows(freqs: &[f64], duties_percent: &[f64], exposure_s: f64) -> Vec<usize> {
    freqs
        .iter()
        .map(|f| {
            let limit = 100.0 * (1.0 - f * exposure_s);
            duties_percent.iter().filter(|&&d| d < limit - 1e-9).count()
        })
        .collect()
}

/// Whether a case's conditions are known (a capture may carry only a
/// source file; its light level, frequency and duty are then 0 in the model
/// and `null` in results.json). Only known cases are on a plane.
fn known(c: &CaseInfo) -> bool {
    c.light_lux > 0.0 && c.frequency_hz > 0.0 && c.duty > 0.0
}

/// Sorted distinct values.
fn distinct(mut v: Vec<f64>) -> Vec<f64> {
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

impl Results {
    /// Light levels of the cases with known conditions, lux, in plan order
    /// of first appearance: one [`LevelPlane`] each.
    pub fn light_levels(&self) -> Vec<f64> {
        self.cases.memo("light levels", || {
            let mut out: Vec<f64> = Vec::new();
            for c in self.cases.iter().filter(|c| known(c)) {
                if !out.contains(&c.light_lux) {
                    out.push(c.light_lux);
                }
            }
            out
        })
    }

    /// The plane of the cases at `light_lux`, showing `metric`; `None`
    /// when no case with known conditions is at that level.
    pub fn plane(&self, light_lux: f64, metric: &str) -> Option<LevelPlane> {
        // What a cell shows of each case at every level, in one pass (kept
        // for the other levels of a spilled run).
        let every_level = self.cases.memo(&format!("cells/{metric}"), || {
            let mut cells: Vec<(f64, PlaneCell)> = Vec::new();
            for case in self.cases.iter().filter(|c| known(c)) {
                let (value, unbounded) = shown_value(&case, metric);
                let cell = PlaneCell {
                    column: 0,
                    row: 0,
                    frequency_hz: case.frequency_hz,
                    duty: case.duty,
                    verdict: metric_verdict(&case, metric),
                    value,
                    unbounded,
                };
                cells.push((case.light_lux, cell));
            }
            std::sync::Arc::new(cells)
        });
        let mut cells: Vec<PlaneCell> = (every_level.iter())
            .filter(|(lux, _)| *lux == light_lux)
            .map(|(_, c)| *c)
            .collect();
        if cells.is_empty() {
            return None;
        }
        let frequencies_hz = distinct(cells.iter().map(|c| c.frequency_hz).collect());
        let duties_percent = distinct(cells.iter().map(|c| c.duty * 100.0).collect());
        cells.retain_mut(|cell| {
            let at = |xs: &[f64], x: f64| xs.binary_search_by(|y| y.total_cmp(&x)).ok();
            let column = at(&frequencies_hz, cell.frequency_hz);
            let row = at(&duties_percent, cell.duty * 100.0);
            let (Some(column), Some(row)) = (column, row) else {
                return false;
            };
            (cell.column, cell.row) = (column, row);
            true
        });
        let eq1 = self
            .dut
            .camera
            .as_ref()
            .filter(|cam| cam.exposure_ms > 0.0)
            .map(|cam| Eq1 {
                exposure_ms: cam.exposure_ms,
                off_rows: eq1_rows(&frequencies_hz, &duties_percent, cam.exposure_ms * 1e-3),
            });
        Some(LevelPlane {
            light_lux,
            frequencies_hz,
            duties_percent,
            cells,
            eq1,
        })
    }
}
